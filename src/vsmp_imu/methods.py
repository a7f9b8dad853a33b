"""Every synthetic-data method the HAR harness can evaluate, registered lazily.

The har room knows only the plug-in point (`vsmp_imu.har.synthetic`); this
module, above all rooms, names the sources: Classical Aug, the IMUTube- and
IMUGPT-2.0-style baselines, VSMP-IMU and its ablation variants. Modules are
imported only when a method is used.
"""

from __future__ import annotations

import importlib
from typing import Any

from vsmp_imu.pipeline.variants import ABLATIONS

# name -> ("module:attribute", display name)
METHOD_TARGETS: dict[str, tuple[str, str]] = {
    "classical": ("vsmp_imu.baselines.classical:ClassicalAugmentation", "Classical Aug."),
    "imutube": ("vsmp_imu.baselines.generative:ImuTubeMethod", "IMUTube"),
    "imugpt": ("vsmp_imu.baselines.generative:ImuGptMethod", "IMUGPT 2.0"),
    **{name: ("vsmp_imu.pipeline.method:make_vsmp_method", display) for name, (display, _) in ABLATIONS.items()},
}
# Methods that generate through the pipeline (they take generation options).
GENERATIVE_PREFIXES = ("vsmp", "imutube", "imugpt")


def add_method(name: str, target: str, display: str | None = None) -> None:
    """Make another synthetic source available (`target` = 'module:attribute')."""
    METHOD_TARGETS[name] = (target, display or name)


def register_all() -> None:
    """Fill the harness's method registry (idempotent)."""
    from vsmp_imu.har.synthetic import METHODS, register_method

    for name, (target, display) in METHOD_TARGETS.items():
        if name in METHODS:
            continue
        module, attr = target.split(":")

        def factory(_module: str = module, _attr: str = attr, **params: Any):
            return getattr(importlib.import_module(_module), _attr)(**params)

        register_method(name, factory, display)


def generative_params(methods, **options: Any) -> dict[str, dict[str, Any]]:
    """Per-method constructor parameters for the generative methods among `methods`."""
    params = {}
    for m in methods:
        if not m.startswith(GENERATIVE_PREFIXES):
            continue
        params[m] = dict(options)
        if m.startswith("vsmp"):
            params[m]["variant"] = m
        else:
            params[m]["k"] = 1  # baselines draw no SMP variants
    return params
