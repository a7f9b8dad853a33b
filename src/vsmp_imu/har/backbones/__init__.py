"""HAR backbones: one estimator interface (`fit(X, y, X_val=None, y_val=None)`,
`predict`, `predict_proba`, `embed`) and a registry by short name."""

from __future__ import annotations

from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.backbones.neural import (
    BiLSTMAttention,
    DeepConvLSTM,
    DeepConvLSTMAttention,
    TorchClassifier,
)
from vsmp_imu.har.backbones.rf import RandomForestECDF, RandomForestSegments

BACKBONES: dict[str, type] = {
    "rf": RandomForestECDF,
    "rf-seg": RandomForestSegments,
    "dclstm": DeepConvLSTM,
    "dclstm-attn": DeepConvLSTMAttention,
    "bilstm-attn": BiLSTMAttention,
}
# Display names used in result tables (the paper's abbreviations).
DISPLAY_NAMES = {"rf": "RF", "rf-seg": "RF-SEG", "dclstm": "DCLSTM", "dclstm-attn": "DCLSTMA", "bilstm-attn": "BLSTMA"}
# Backbone parameters that change how fast a model trains, not what it learns.
RUN_PARAMS = ("n_jobs", "n_threads", "verbose")


def register_backbone(name: str, cls: type, display: str | None = None) -> None:
    """Add a backbone class under a short name (used by `--backbones`)."""
    BACKBONES[name] = cls
    DISPLAY_NAMES[name] = display or name


def make_backbone(name: str, **params: Any):
    """A new backbone by short name; a parameter it does not take is a ConfigError."""
    try:
        cls = BACKBONES[name]
    except KeyError:
        raise ConfigError(
            f"unknown backbone '{name}'", field="backbones", allowed=", ".join(BACKBONES)
        ) from None
    accepted = cls().get_params()
    unknown = sorted(set(params) - set(accepted))
    if unknown:
        raise ConfigError(
            f"backbone '{name}' takes no parameter(s) {', '.join(unknown)}",
            field="backbone_params",
            allowed=", ".join(sorted(accepted)),
        )
    return cls(**params)


def option_params(name: str, *, jobs: int | None = None, max_epochs: int | None = None,
                  patience: int | None = None, device: str | None = None,
                  class_weight: str | None = None) -> dict[str, Any]:
    """The command-line options that reach backbone `name`, read from its own parameters:
    `--jobs` is a forest's `n_jobs` and a network's `n_threads`; `--max-epochs`,
    `--patience`, `--device` and `--class-weight` reach the backbones that take them. An
    option not given (None) is left to the backbone's default."""
    accepted = make_backbone(name).get_params()
    given = {"n_jobs": jobs, "n_threads": jobs, "max_epochs": max_epochs, "patience": patience,
             "device": device, "class_weight": class_weight}
    return {k: v for k, v in given.items() if v is not None and k in accepted}


__all__ = [
    "BACKBONES",
    "DISPLAY_NAMES",
    "RUN_PARAMS",
    "BiLSTMAttention",
    "DeepConvLSTM",
    "DeepConvLSTMAttention",
    "RandomForestECDF",
    "RandomForestSegments",
    "TorchClassifier",
    "make_backbone",
    "option_params",
    "register_backbone",
]
