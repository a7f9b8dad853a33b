"""HAR evaluation: windows, datasets and loaders, backbones, protocols, metrics and the
plug-in point for synthetic data. Imports nothing of the project above it.

Names are imported on first use, so `import vsmp_imu.har.synthetic` stays light
(no scikit-learn or PyTorch until a backbone is needed).
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "BACKBONES": "backbones",
    "make_backbone": "backbones",
    "register_backbone": "backbones",
    "DatasetInfo": "dataset",
    "HarDataset": "dataset",
    "Recording": "dataset",
    "SensorLocation": "dataset",
    "axes_matrix": "dataset",
    "measure_static_gravity": "dataset",
    "DATASETS": "datasets",
    "dataset_names": "datasets",
    "load_dataset": "datasets",
    "register_dataset": "datasets",
    "EvalConfig": "evaluate",
    "Evaluation": "evaluate",
    "EvalResults": "evaluate",
    "summarize": "evaluate",
    "ecdf_features": "features",
    "ecdf_levels": "features",
    "evaluate_predictions": "metrics",
    "macro_f1": "metrics",
    "ChannelStandardizer": "normalize",
    "PROTOCOLS": "protocols",
    "FoldSplit": "protocols",
    "split_fold": "protocols",
    "METHODS": "synthetic",
    "FoldContext": "synthetic",
    "SyntheticSource": "synthetic",
    "make_method": "synthetic",
    "register_method": "synthetic",
    "synthetic_budget": "synthetic",
    "Windows": "windows",
    "concat_windows": "windows",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'vsmp_imu.har' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"vsmp_imu.har.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
