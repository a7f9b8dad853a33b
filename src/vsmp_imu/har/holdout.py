"""Whether a dataset's windows leave a fold to generate for a held-out subject, and if not, why.

A subject the dataset lists can still have no window (its recordings are shorter than a window,
or no class is labelled over one), and a rate that does not fit the recordings leaves no window
at all. The messages say so, with the recordings' lengths, instead of calling the subject unknown.
"""

from __future__ import annotations

from vsmp_imu.errors import ConfigError


def source_of(dataset):
    """The file (or folder) the dataset was read from, for a message; None for a built-in one."""
    return getattr(dataset, "yaml_path", None) or getattr(dataset, "data_dir", None)


def longest_recording(dataset, subject: str | None = None) -> str:
    """The longest recording (of `subject`, else of all), as '0.02 s (1 sample at 50 Hz)'."""
    n = max((r.n_samples for r in dataset.recordings() if subject is None or r.subject == subject), default=0)
    fs = dataset.info.fs_hz
    return f"{round(n / fs, 3):g} s ({n} sample{'' if n == 1 else 's'} at {fs:g} Hz)"


def require_windows(dataset, windows, window_s: float) -> None:
    """A dataset that gives no labelled window at all is refused, with its longest recording."""
    if len(windows):
        return
    raise ConfigError(f"dataset '{dataset.info.name}' gives no labelled window of {window_s:g} s: its longest "
                      f"recording lasts {longest_recording(dataset)}", file=source_of(dataset),
                      allowed=f"a rate (fs_hz) and recordings that give windows of {window_s:g} s with a class "
                              "labelled over them")


def require_holdout(dataset, windows, holdout: str, window_s: float) -> None:
    """`holdout` must be a subject with windows, and the other subjects must have windows to train on."""
    name, with_windows = dataset.info.name, windows.unique_subjects()
    allowed = ", ".join(with_windows)
    if holdout not in dataset.subjects:
        raise ConfigError(f"subject '{holdout}' is not in {name}", field="--holdout", allowed=allowed)
    if holdout not in with_windows:
        raise ConfigError(f"subject '{holdout}' is in {name} but has no labelled window of {window_s:g} s: its "
                          f"longest recording lasts {longest_recording(dataset, holdout)}", field="--holdout",
                          allowed=allowed)
    if with_windows == [holdout]:
        raise ConfigError(f"holding out '{holdout}' leaves no real training windows: it is the only subject of "
                          f"{name} with labelled windows of {window_s:g} s", field="--holdout",
                          allowed="a dataset with at least 2 subjects that have windows")
