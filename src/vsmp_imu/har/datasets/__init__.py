"""Dataset registry: `load_dataset(name_or_path, data_dir=None)`."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.dataset import HarDataset

# name -> (factory(data_dir), needs a data folder, one-line description)
DATASETS: dict[str, tuple[Callable[[Path | None], HarDataset], bool, str]] = {}


def register_dataset(
    name: str, factory: Callable[[Path | None], HarDataset], needs_data_dir: bool, description: str
) -> None:
    DATASETS[name] = (factory, needs_data_dir, description)


def _hapt(_: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.hapt import HAPT

    return HAPT(with_transitions=False)


def _hapt12(_: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.hapt import HAPT

    return HAPT(with_transitions=True)


def _pamap2(d: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.pamap2 import PAMAP2

    return PAMAP2(d)


def _utd(d: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.utd_mhad import UTDMHAD

    return UTDMHAD(d)


def _mmfit(d: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.mmfit import MMFit

    return MMFit(d)


def _mmact(d: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.mmact import MMAct

    return MMAct(d)


def _hadaw(d: Path | None) -> HarDataset:
    from vsmp_imu.har.datasets.hadaw import HADAW

    return HADAW(d)


register_dataset("hapt", _hapt, False, "UCI HAPT, 6 activities, waist phone, 50 Hz (ships offline)")
register_dataset(
    "hapt12", _hapt12, False, "UCI HAPT, 6 activities + 6 postural transitions (ships offline)"
)
register_dataset("mmfit", _mmfit, True, "MM-Fit, 10 exercises, watches/phone/earbud (--data-dir)")
register_dataset("utd-mhad", _utd, True, "UTD-MHAD inertial, 27 actions, wrist/thigh (--data-dir)")
register_dataset(
    "mmact", _mmact, True, "MMAct trimmed inertial, 37 actions, phone+watch (--data-dir)"
)
register_dataset(
    "pamap2", _pamap2, True, "PAMAP2, 18 activities, hand/chest/ankle, 100 Hz (--data-dir)"
)
register_dataset("had-aw", _hadaw, True, "HAD-AW Apple Watch activities (--data-dir)")


def dataset_names() -> list[str]:
    return list(DATASETS)


def load_dataset(name_or_path: str | Path, data_dir: str | Path | None = None) -> HarDataset:
    """A dataset by registered name, or from a generic-format YAML file path."""
    text = str(name_or_path)
    if text.lower().endswith((".yaml", ".yml")):
        from vsmp_imu.har.datasets.generic import GenericDataset

        if not Path(text).exists():
            raise InputFileError("dataset YAML file not found", file=text)
        if data_dir is not None:
            raise ConfigError("a dataset YAML file names its own data folder (its 'data' field)",
                              field="--data-dir", allowed="leave out --data-dir with a dataset .yaml file")
        return GenericDataset(text)
    if text not in DATASETS:
        raise ConfigError(
            f"unknown dataset '{text}'",
            field="--dataset",
            allowed=", ".join(DATASETS) + ", or a path to a dataset .yaml file",
        )
    factory, needs_dir, _ = DATASETS[text]
    if data_dir is not None and not needs_dir:
        raise ConfigError(f"dataset '{text}' ships with the package and reads no folder", field="--data-dir",
                          allowed="leave out --data-dir (it names the folder of a downloaded dataset: "
                                  + ", ".join(n for n, (_, d, _) in DATASETS.items() if d) + ")")
    if needs_dir:
        if data_dir is None:
            raise ConfigError(
                f"dataset '{text}' is read from a local folder; give --data-dir", field="--data-dir"
            )
        if not Path(data_dir).is_dir():
            raise InputFileError("data folder not found", file=data_dir)
    return factory(Path(data_dir) if data_dir is not None else None)


__all__ = ["DATASETS", "dataset_names", "load_dataset", "register_dataset"]
