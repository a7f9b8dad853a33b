"""The `Motion` type: a skeleton animation in metres, Y-up, with global rotations.

File format (.npz) has exactly the keys `positions`, `rotations`, `fps`,
`joint_names`, `parents` and `meta` (JSON text). Rotations are global joint
orientations as quaternions in scipy order (x, y, z, w).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.interpolate import interp1d
from scipy.spatial.transform import Rotation, Slerp

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.io import write_bytes
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, SMPL22_PARENTS, estimate_height

# The largest motion we write: 600 s at 1000 fps of 22 joints (positions and quaternions) is
# 0.7 GiB; a motion file that unpacks to more is refused before it is read.
MAX_NPZ_BYTES = 2**30
NPZ_KEYS = ("positions", "rotations", "fps", "joint_names", "parents", "meta")


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
                f"no joint named '{name}'", field="joint", allowed=", ".join(self.joint_names)
            ) from None

    def body_height_m(self) -> float:
        """Estimated standing height of the skeleton (from bone lengths)."""
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
        if fps <= 0:
            raise ValidationError(f"fps must be positive, got {fps}", field="fps")
        t_old = self.times
        n_new = int(np.floor(self.duration_s * fps + 1e-9)) + 1
        t_new = np.arange(n_new) / fps
        kind = "cubic" if self.n_frames >= 4 else "linear"
        pos = interp1d(t_old, self.positions, axis=0, kind=kind)(t_new)
        rot = np.empty((n_new, self.n_joints, 4))
        for j in range(self.n_joints):
            rot[:, j] = Slerp(t_old, Rotation.from_quat(self.rotations[:, j]))(t_new).as_quat()
        meta = dict(self.meta, resampled_from_fps=self.fps)
        return Motion(pos, rot, fps, self.joint_names, self.parents, meta)

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
        """Write a .npz atomically."""
        return write_bytes(path, self.to_npz_bytes())

    @classmethod
    def load(cls, path: str | Path) -> Motion:
        path = Path(path)
        if not path.exists():
            raise InputFileError("file not found", file=path)
        try:
            with np.load(path, allow_pickle=False) as npz:
                unpacked = sum(info.file_size for info in npz.zip.infolist())
                if unpacked > MAX_NPZ_BYTES:  # a zip bomb: refused before anything is inflated
                    raise InputFileError(f"the motion would unpack to {unpacked / 2**20:.0f} MiB", file=path,
                                         allowed=f"at most {MAX_NPZ_BYTES // 2**20} MiB")
                missing = [k for k in NPZ_KEYS if k not in npz.files and k != "meta"]
                if missing:
                    raise InputFileError(
                        f"not a motion file: missing key(s) {', '.join(missing)}",
                        file=path,
                        allowed="an .npz with keys " + ", ".join(NPZ_KEYS),
                    )
                meta = json.loads(str(npz["meta"])) if "meta" in npz.files else {}
                return cls(
                    positions=npz["positions"],
                    rotations=npz["rotations"],
                    fps=float(npz["fps"]),
                    joint_names=tuple(npz["joint_names"].tolist()),
                    parents=tuple(npz["parents"].tolist()),
                    meta=meta,
                )
        except InputFileError:
            raise
        except ValidationError as exc:
            raise ValidationError(exc.message, file=path, field=exc.field) from exc
        except Exception as exc:  # zipfile.BadZipFile, ValueError, OSError, ...
            raise InputFileError(f"cannot read motion .npz ({type(exc).__name__}: {exc})", file=path) from exc
