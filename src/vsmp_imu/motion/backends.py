"""Motion backends behind one interface: `generate(smp_or_prompt, seed, duration_s=None) -> Motion`."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

from vsmp_imu.errors import ConfigError
from vsmp_imu.motion.motion import Motion
from vsmp_imu.smp.schema import SMP

BACKENDS = ("procedural", "compiled", "hymotion")


@runtime_checkable
class MotionBackend(Protocol):
    """What every motion backend provides."""

    name: str

    def generate(self, smp_or_prompt: SMP | str, seed: int, duration_s: float | None = None) -> Motion:
        """One motion for an SMP (or a free-text prompt) and a seed."""
        ...


def get_backend(name: str, **kwargs: Any) -> MotionBackend:
    """A backend by name; keyword arguments go to its constructor.

    'procedural': library recipes, SMPs without one compiled; 'compiled': the
    procedural backend with every motion compiled from its SMP (recipes ignored);
    'hymotion': HY-Motion 1.0.
    """
    key = backend_name(name)
    if key == "procedural":
        from vsmp_imu.motion.procedural import ProceduralBackend

        return ProceduralBackend(**kwargs)
    if key == "compiled":
        from vsmp_imu.motion.procedural import ProceduralBackend

        return ProceduralBackend(compile_mode="always", **kwargs)
    from vsmp_imu.motion.hymotion import HYMotionBackend

    return HYMotionBackend(**kwargs)


def backend_name(name: str) -> str:
    """The backend `name` stands for (case, '-' and '_' aside: 'HY-Motion' is 'hymotion'); a
    ConfigError when none (cheap: a command checks its option before any work)."""
    key = str(name).strip().lower().replace("-", "").replace("_", "")
    key = {"hymotion1": "hymotion", "hymotion10": "hymotion"}.get(key, key)
    if key not in BACKENDS:
        raise ConfigError(f"unknown motion backend '{name}'", field="backend", allowed=", ".join(BACKENDS))
    return key


def check_backend(name: str, field: str = "backend") -> None:
    """Refuse a name `get_backend` does not take, before any work (nothing is imported)."""
    try:
        backend_name(name)
    except ConfigError as exc:
        raise exc.in_field(field) from None
