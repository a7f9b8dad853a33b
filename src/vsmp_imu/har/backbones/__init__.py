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
from vsmp_imu.har.backbones.rf import RandomForestECDF

BACKBONES: dict[str, type] = {
    "rf": RandomForestECDF,
    "dclstm": DeepConvLSTM,
    "dclstm-attn": DeepConvLSTMAttention,
    "bilstm-attn": BiLSTMAttention,
}
# Display names used in result tables (the paper's abbreviations).
DISPLAY_NAMES = {"rf": "RF", "dclstm": "DCLSTM", "dclstm-attn": "DCLSTMA", "bilstm-attn": "BLSTMA"}


def register_backbone(name: str, cls: type, display: str | None = None) -> None:
    """Add a backbone class under a short name (used by `--backbones`)."""
    BACKBONES[name] = cls
    DISPLAY_NAMES[name] = display or name


def make_backbone(name: str, **params: Any):
    """A new backbone by short name; `params` not accepted by it are ignored."""
    try:
        cls = BACKBONES[name]
    except KeyError:
        raise ConfigError(
            f"unknown backbone '{name}'", field="backbones", allowed=", ".join(BACKBONES)
        ) from None
    accepted = cls().get_params()
    return cls(**{k: v for k, v in params.items() if k in accepted})


__all__ = [
    "BACKBONES",
    "DISPLAY_NAMES",
    "BiLSTMAttention",
    "DeepConvLSTM",
    "DeepConvLSTMAttention",
    "RandomForestECDF",
    "TorchClassifier",
    "make_backbone",
    "register_backbone",
]
