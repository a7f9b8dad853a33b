"""The `Motion` type: a skeleton animation in metres, Y-up, with global rotations.

File format (.npz) has exactly the keys `positions`, `rotations`, `fps`,
`joint_names`, `parents` and `meta` (JSON text). Rotations are global joint
orientations as quaternions in scipy order (x, y, z, w). `Motion.load` checks
a file's structure and values (`Motion.check_values`) before any command uses it.
"""

from __future__ import annotations

import io
import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import interp1d
from scipy.spatial.transform import Rotation, Slerp

from vsmp_imu.errors import InputFileError, ValidationError, some_of
from vsmp_imu.io import check_regular_file, write_bytes
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, SMPL22_PARENTS, estimate_height
from vsmp_imu.smp.schema import MAX_MOTION_S

# The largest motion we write: 600 s at 1000 fps of 22 joints (positions and quaternions) is
# 0.7 GiB; a motion file that unpacks to more is refused before it is read.
MAX_NPZ_BYTES = 2**30
NPZ_KEYS = ("positions", "rotations", "fps", "joint_names", "parents", "meta")
# What the values of a motion file may be (`Motion.check_values`):
MIN_FPS, MAX_FPS = 1.0, 1000.0  # the rates `motion synth --fps` and `motion resample --fps` accept
MAX_DURATION_S = MAX_MOTION_S  # the longest motion synthesis makes (600 s)
MAX_POSITION_M = 1e4  # |coordinate| bound; ten minutes of running travel about 1 km
MIN_QUAT_NORM, MAX_QUAT_NORM = 1e-3, 1e3  # quaternions are normalized where used


@dataclass
class Motion:
    """A motion sequence.

    positions: (T, J, 3) joint positions in metres, world frame Y-up.
    rotations: (T, J, 4) global joint orientations, quaternions (x, y, z, w).
    fps: frames per second.
    joint_names, parents: the skeleton topology (parents[root] = -1).
    meta: provenance (source, seed, smp_id, prompt, backend, ...), JSON-serializable.
    """

    positions: np.ndarray
    rotations: np.ndarray
    fps: float
    joint_names: tuple[str, ...] = SMPL22_JOINTS
    parents: tuple[int, ...] = SMPL22_PARENTS
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.positions = np.asarray(self.positions, dtype=np.float64)
        self.rotations = np.asarray(self.rotations, dtype=np.float64)
        self.joint_names = tuple(str(n) for n in self.joint_names)
        self.parents = tuple(int(p) for p in self.parents)
        self.fps = float(self.fps)
        self.validate()

    # -- checks -------------------------------------------------------------
    def validate(self) -> None:
        t, j = self.positions.shape[:2] if self.positions.ndim == 3 else (None, None)
        if self.positions.ndim != 3 or self.positions.shape[2] != 3:
            raise ValidationError(f"positions must be (T, J, 3), got {self.positions.shape}", field="positions")
        if self.rotations.shape != (t, j, 4):
            raise ValidationError(
                f"rotations must be (T, J, 4) = {(t, j, 4)}, got {self.rotations.shape}", field="rotations"
            )
        if len(self.joint_names) != j or len(self.parents) != j:
            raise ValidationError(
                f"{j} joints in positions but {len(self.joint_names)} names and {len(self.parents)} parents",
                field="joint_names",
            )
        if not (self.fps > 0 and np.isfinite(self.fps)):
            raise ValidationError(f"fps must be positive, got {self.fps}", field="fps")
        if t < 2:
            raise ValidationError(f"a motion needs at least 2 frames, got {t}", field="positions")
        _check_names(self.joint_names)
        _check_parents(self.parents)
        if not isinstance(self.meta, dict):
            raise ValidationError(f"must be a mapping, got {type(self.meta).__name__}", field="meta")

    def check_values(self) -> None:
        """Refuse values no command can use: a frame rate or duration out of range, non-finite or
        far-off positions, quaternions that cannot be normalized (what `load` checks in a file)."""
        if not MIN_FPS <= self.fps <= MAX_FPS:
            raise ValidationError(f"{self.fps:g} fps is out of range", field="fps",
                                  allowed=f"{MIN_FPS:g}..{MAX_FPS:g}")
        if self.duration_s > MAX_DURATION_S + 1e-6:  # slack for the rounding of (T - 1) / fps
            raise ValidationError(f"{self.n_frames} frames at {self.fps:g} fps last {self.duration_s:.6g} s",
                                  field="positions", allowed=f"a motion of at most {MAX_DURATION_S:g} s")
        _check_array(self.positions, "positions", "a coordinate", 0.0, MAX_POSITION_M,
                     f"finite coordinates within ±{MAX_POSITION_M:g} m")
        with np.errstate(over="ignore", under="ignore", invalid="ignore"):
            norms = np.linalg.norm(self.rotations, axis=-1)
        _check_array(norms, "rotations", "a quaternion norm", MIN_QUAT_NORM, MAX_QUAT_NORM,
                     f"finite quaternions of norm {MIN_QUAT_NORM:g}..{MAX_QUAT_NORM:g}")

    # -- views ----------------------------------------------------------------
    @property
    def n_frames(self) -> int:
        return int(self.positions.shape[0])

    @property
    def n_joints(self) -> int:
        return int(self.positions.shape[1])

    @property
    def duration_s(self) -> float:
        return (self.n_frames - 1) / self.fps

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.n_frames) / self.fps

    def joint_index(self, name: str) -> int:
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise ValidationError(
                f"no joint named '{name}'", field="joint", allowed=some_of(self.joint_names, 30)
            ) from None

    def body_height_m(self) -> float:
        """Estimated standing height of the skeleton (from bone lengths); needs the SMPL-22
        ankle-to-head joints (a ValidationError names the missing ones)."""
        return estimate_height(self.positions, self.joint_names)

    @property
    def single_execution(self) -> bool:
        """Whether the motion is one execution of a discrete activity (a transition, a throw), not a
        rhythm or a held posture: its windows have no tempo, and what they average to depends on
        its timing."""
        controls = self.meta.get("controls") or {}
        return controls.get("repetitions") == 1 and controls.get("continuous") is False

    def is_finite(self) -> bool:
        return bool(np.isfinite(self.positions).all() and np.isfinite(self.rotations).all())

    # -- transforms -----------------------------------------------------------
    def resample(self, fps: float) -> Motion:
        """The same motion at another frame rate (cubic positions, slerp rotations)."""
        n_new = self._resampled_frames(fps)
        t_old = self.times
        t_new = np.arange(n_new) / fps
        kind = "cubic" if self.n_frames >= 4 else "linear"
        pos = interp1d(t_old, self.positions, axis=0, kind=kind)(t_new)
        rot = np.empty((n_new, self.n_joints, 4))
        for j in range(self.n_joints):
            rot[:, j] = Slerp(t_old, Rotation.from_quat(self.rotations[:, j]))(t_new).as_quat()
        meta = dict(self.meta, resampled_from_fps=self.fps)
        return Motion(pos, rot, fps, self.joint_names, self.parents, meta)

    def _resampled_frames(self, fps: float) -> int:
        """The frame count at `fps`; refuses a rate out of range, a count below 2 or a result
        larger than a motion file may be."""
        if not MIN_FPS <= fps <= MAX_FPS:  # NaN fails too
            raise ValidationError(f"{fps:g} fps is out of range", field="fps", allowed=f"{MIN_FPS:g}..{MAX_FPS:g}")
        if not self.is_finite():
            raise ValidationError("the motion has non-finite positions or rotations", field="positions")
        n_new = int(np.floor(self.duration_s * fps + 1e-9)) + 1
        if n_new < 2:
            raise ValidationError(f"the motion's {self.duration_s:.6g} s give 1 frame at {fps:g} fps",
                                  field="fps", allowed=f"at least {1 / self.duration_s:.6g} fps (2 frames)")
        size = n_new * self.n_joints * 7 * 8  # float64 positions and quaternions
        if size > MAX_NPZ_BYTES:
            raise ValidationError(f"the motion at {fps:g} fps would be {size / 2**20:.0f} MiB", field="fps",
                                  allowed=f"a motion file of at most {MAX_NPZ_BYTES // 2**20} MiB")
        return n_new

    # -- files ------------------------------------------------------------------
    def to_npz_bytes(self) -> bytes:
        buf = io.BytesIO()
        np.savez(
            buf,
            positions=self.positions,
            rotations=self.rotations,
            fps=np.float64(self.fps),
            joint_names=np.array(self.joint_names),
            parents=np.array(self.parents, dtype=np.int64),
            meta=np.array(json.dumps(self.meta, sort_keys=True, default=str)),
        )
        return buf.getvalue()

    def save(self, path: str | Path) -> Path:
        """Write a .npz atomically; a motion `load` would refuse is refused here, naming the file."""
        try:
            self.check_values()
        except ValidationError as exc:
            raise exc.in_file(path) from exc
        return write_bytes(path, self.to_npz_bytes())

    @classmethod
    def load(cls, path: str | Path) -> Motion:
        """Read a motion file; what no command can use is refused, naming the file and the field."""
        path = Path(path)
        _check_npz_file(path)
        try:
            with np.load(path, allow_pickle=False) as npz:
                _check_npz_keys(npz, path)
                motion = cls(**_read_fields(npz))
            motion.check_values()
            return motion
        except InputFileError:
            raise
        except ValidationError as exc:
            raise exc.in_file(path) from exc
        except Exception as exc:  # zipfile.BadZipFile, a corrupt member, OSError, ...
            raise InputFileError(f"cannot read motion .npz ({type(exc).__name__}: {exc})", file=path) from exc


# -- reading a file -----------------------------------------------------------------
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # np.load reads these as .npz, other bytes as .npy or a pickle
_NPZ_ALLOWED = "an .npz with keys " + ", ".join(NPZ_KEYS)


def _check_npz_file(path: Path) -> None:
    """Refuse a missing file, a folder, or a file that is not a zip archive (checked here, so
    that numpy never takes a text file for a pickle)."""
    if not path.exists():
        raise InputFileError("file not found", file=path)
    if path.is_dir():
        raise InputFileError("is a folder, not a motion file", file=path, allowed=_NPZ_ALLOWED)
    check_regular_file(path)
    try:
        with path.open("rb") as fh:
            head = fh.read(4)
    except OSError as exc:
        raise InputFileError(f"cannot read the file ({exc.strerror or exc})", file=path) from exc
    if not head.startswith(_ZIP_MAGIC):
        raise InputFileError("not a motion file (.npz): not a zip archive", file=path, allowed=_NPZ_ALLOWED)


def _check_npz_keys(npz: Any, path: Path) -> None:
    """Refuse a zip that would unpack to too much, or one without the motion keys."""
    unpacked = sum(info.file_size for info in npz.zip.infolist())
    if unpacked > MAX_NPZ_BYTES:  # a zip bomb: refused before anything is inflated
        raise InputFileError(f"the motion would unpack to {unpacked / 2**20:.0f} MiB", file=path,
                             allowed=f"at most {MAX_NPZ_BYTES // 2**20} MiB")
    missing = [k for k in NPZ_KEYS if k not in npz.files and k != "meta"]
    if missing:
        raise InputFileError(f"not a motion file: missing key(s) {', '.join(missing)}", file=path,
                             allowed=_NPZ_ALLOWED)


def _read_fields(npz: Any) -> dict[str, Any]:
    """The `Motion` fields of an open .npz, each of the type its field needs."""
    return {
        "positions": _numbers(npz["positions"], "positions"),
        "rotations": _numbers(npz["rotations"], "rotations"),
        "fps": _fps(npz["fps"]),
        "joint_names": _names(npz["joint_names"]),
        "parents": _parents(npz["parents"]),
        "meta": _meta(npz["meta"]) if "meta" in npz.files else {},
    }


def _numbers(arr: np.ndarray, key: str) -> np.ndarray:
    if arr.dtype.kind not in "iuf":
        raise ValidationError(f"must be numbers, got {arr.dtype}", field=key)
    return arr


def _fps(arr: np.ndarray) -> float:
    if arr.size != 1 or arr.dtype.kind not in "iuf":
        raise ValidationError(f"must be one number, got {arr.size} value(s) of type {arr.dtype}", field="fps")
    return float(arr.reshape(()))


def _names(arr: np.ndarray) -> tuple[str, ...]:
    if arr.ndim != 1 or arr.dtype.kind != "U":
        raise ValidationError(f"must be a list of text, got {arr.dtype} of shape {arr.shape}",
                              field="joint_names")
    return tuple(arr.tolist())


def _parents(arr: np.ndarray) -> tuple[int, ...]:
    if arr.ndim != 1 or arr.dtype.kind not in "iu":
        raise ValidationError(f"must be a list of integers, got {arr.dtype} of shape {arr.shape}",
                              field="parents")
    return tuple(arr.tolist())


def _meta(arr: np.ndarray) -> dict[str, Any]:
    if arr.shape != () or arr.dtype.kind != "U":
        raise ValidationError(f"must be JSON text, got {arr.dtype} of shape {arr.shape}", field="meta")
    try:
        meta = json.loads(str(arr))
    except ValueError as exc:  # JSONDecodeError, an integer too long to convert
        raise ValidationError(f"not JSON ({exc})", field="meta") from None
    except RecursionError:  # json.loads gives up near 1000 nested lists or objects
        raise ValidationError("the JSON nests lists or objects too deeply to read", field="meta",
                              allowed="a JSON object nested at most a few hundred levels") from None
    if not isinstance(meta, dict):
        raise ValidationError(f"must be a JSON object {{...}}, got {str(arr)[:40]!r}", field="meta")
    return meta


# -- checks -------------------------------------------------------------------------
def _check_names(names: tuple[str, ...]) -> None:
    blank = [n for n in names if not n or any(c.isspace() for c in n)]
    if blank:
        raise ValidationError(f"joint name {blank[0]!r} is empty or has white space", field="joint_names")
    twice = sorted(n for n, k in Counter(names).items() if k > 1)
    if twice:
        raise ValidationError(f"joint name(s) {', '.join(twice)} given more than once", field="joint_names")


def _check_parents(parents: tuple[int, ...]) -> None:
    """The parents form one tree: indices of joints, one root (-1), every joint below it."""
    n = len(parents)
    for j, p in enumerate(parents):
        if not -1 <= p < n:
            raise ValidationError(f"parent {p} of joint {j} is not a joint", field="parents",
                                  allowed=f"-1 (the root) or 0..{n - 1}")
    roots = parents.count(-1)
    if roots != 1:
        raise ValidationError(f"a skeleton has one root (parent -1), this one has {roots}", field="parents")
    cut = _cut_off(parents)
    if cut:
        raise ValidationError(f"joint(s) {some_of(cut, 10)} do not descend from the root (a cycle in their parents)",
                              field="parents")


def _cut_off(parents: tuple[int, ...]) -> list[int]:
    """Joints whose chain of parents never reaches -1, in one pass."""
    reached, cut = {-1}, set()
    for j in range(len(parents)):
        chain: set[int] = set()
        k = j
        while k not in reached and k not in cut and k not in chain:
            chain.add(k)
            k = parents[k]
        (reached if k in reached else cut).update(chain)
    return sorted(cut)


def _check_array(values: np.ndarray, field: str, what: str, low: float, high: float, allowed: str) -> None:
    """Refuse a non-finite value or one whose magnitude is outside low..high, naming where it is."""
    magnitude = np.abs(values)
    bad = ~np.isfinite(values) | (magnitude < low) | (magnitude > high)
    if bad.any():
        where = tuple(np.argwhere(bad)[0])
        raise ValidationError(f"{what} of {values[where]:.6g} at frame {where[0]}, joint {where[1]}",
                              field=field, allowed=allowed)
