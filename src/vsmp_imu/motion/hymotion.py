"""The HY-Motion 1.0 backend: a verbalized SMP -> Tencent's text-to-motion model -> `Motion`.

HY-Motion 1.0 (github.com/Tencent-Hunyuan/HY-Motion-1.0) is used through its
published runtime, `hymotion.utils.t2m_runtime.T2MRuntime`, whose
`generate_motion(text, seeds_csv, duration, cfg_scale, output_format="dict")`
returns `(html, fbx_files, output)`. `output` holds torch tensors, batch
first (one batch row per seed):

- `rot6d` (B, L, 22, 6): local joint rotations of the SMPL-H body in the
  6D form of Zhou et al. (the first two columns of the rotation matrix,
  row-major: m00 m01 m10 m11 m20 m21); joint 0 is the root's global
  orientation, the others are relative to their SMPL parent;
- `transl` (B, L, 3): root translation, metres, Y up;
- `keypoints3d` (B, L, 52, 3): joint positions from the runtime's skinning
  model *without* the translation, the first 22 being the SMPL body joints;
- `root_rotations_mat` (B, L, 3, 3), `latent_denorm` (B, L, 201), `text`.

Before returning, the runtime lowers `keypoints3d` and `transl` by the
lowest mesh vertex of the sequence (it grounds the mesh). Joint positions are
therefore `keypoints3d + transl` up to that constant; this backend grounds
them again with its own rule (the lowest foot joint rests at its sole height)
and records the shift in `meta["floor_shift_m"]`. Output is 30 fps, 0.5 to
12 s (the runtime clamps its frame count to that range).

Licence: the Tencent HY-Motion 1.0 Community License does not apply in the
European Union, the United Kingdom and South Korea, and forbids using its
outputs to improve any other AI model (docs/motion.md).
"""

from __future__ import annotations

import importlib.util
import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import DependencyError, InputFileError, ValidationError
from vsmp_imu.motion import quat
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import (
    DEFAULT_HEIGHT_M,
    SMPL22_JOINTS,
    SMPL22_PARENTS,
    estimate_height,
)
from vsmp_imu.smp.schema import SMP

BACKEND_NAME = "hymotion"
HY_FPS = 30.0
HY_MIN_DURATION_S, HY_MAX_DURATION_S = 0.5, 12.0
HY_BODY_JOINTS = 22
DEFAULT_CFG_SCALE = 5.0
DEFAULT_DURATION_S = 5.0  # when neither the call nor the SMP gives one
MODEL_PATH_ENV = "VSMP_HYMOTION_MODEL"
DEFAULT_MODEL_PATH = "ckpts/tencent/HY-Motion-1.0"
OUTPUT_KEYS = ("rot6d", "transl", "keypoints3d")
# Height of the foot joints above the sole for a 1.70 m SMPL body (m).
_SOLE_170 = {"left_ankle": 0.07, "right_ankle": 0.07, "left_foot": 0.024, "right_foot": 0.024}
INSTALL_HINT = (
    "install it from github.com/Tencent-Hunyuan/HY-Motion-1.0 (clone the repository, "
    "`pip install -r requirements.txt`, put the clone on PYTHONPATH) on a machine with a CUDA GPU"
)


# -- rotation conversions -------------------------------------------------------------
def rot6d_to_matrix(rot6d: np.ndarray) -> np.ndarray:
    """(..., 6) HY-Motion 6D rotations -> (..., 3, 3) matrices (Gram-Schmidt on two columns)."""
    x = np.asarray(rot6d, dtype=np.float64).reshape(*np.shape(rot6d)[:-1], 3, 2)
    a1, a2 = x[..., 0], x[..., 1]
    b1 = a1 / np.linalg.norm(a1, axis=-1, keepdims=True)
    b2 = a2 - (b1 * a2).sum(axis=-1, keepdims=True) * b1
    b2 = b2 / np.linalg.norm(b2, axis=-1, keepdims=True)
    b3 = np.cross(b1, b2)
    return np.stack([b1, b2, b3], axis=-1)


def matrix_to_rot6d(matrix: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 6): the first two columns, row-major (HY-Motion's layout)."""
    m = np.asarray(matrix, dtype=np.float64)
    return m[..., :, :2].reshape(*m.shape[:-2], 6)


def _numpy(value: Any, key: str) -> np.ndarray:
    if hasattr(value, "detach"):  # torch tensor
        value = value.detach().cpu().numpy()
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValidationError(f"HY-Motion output '{key}' is not numeric ({exc})", field=key) from None


def _batch(array: np.ndarray, key: str, index: int, tail: tuple[int | None, ...]) -> np.ndarray:
    """Row `index` of a batch-first array, shape-checked against (B, L, *tail)."""
    if array.ndim != 2 + len(tail):
        raise ValidationError(f"HY-Motion output '{key}' must have {2 + len(tail)} axes "
                              f"(batch, frames, ...), got shape {array.shape}", field=key)
    for want, got in zip(tail, array.shape[2:], strict=True):
        if want is not None and got < want:
            raise ValidationError(f"HY-Motion output '{key}' has shape {array.shape}; expected at "
                                  f"least {want} on a trailing axis", field=key)
    if not 0 <= index < array.shape[0]:
        raise ValidationError(f"batch index {index} out of range for {array.shape[0]} motion(s)",
                              field="index")
    return array[index]


def motion_from_hymotion(output: Mapping[str, Any], index: int = 0, fps: float = HY_FPS,
                         meta: Mapping[str, Any] | None = None) -> Motion:
    """Convert one batch row of HY-Motion's output dict into a `Motion`.

    Rotations: global = parent's global x local, through the SMPL-22 tree.
    Positions: keypoints3d (22 body joints) + transl, re-grounded so the lowest
    foot joint of the sequence rests at its sole height.
    """
    if not isinstance(output, Mapping):
        raise ValidationError(f"HY-Motion output must be a mapping, got {type(output).__name__}",
                              field="output")
    missing = [k for k in OUTPUT_KEYS if k not in output]
    if missing:
        raise ValidationError(f"HY-Motion output lacks {', '.join(missing)}", field="output",
                              allowed="a dict with keys " + ", ".join(OUTPUT_KEYS))
    rot6d = _batch(_numpy(output["rot6d"], "rot6d"), "rot6d", index, (HY_BODY_JOINTS, 6))
    transl = _batch(_numpy(output["transl"], "transl"), "transl", index, (3,))
    kp = _batch(_numpy(output["keypoints3d"], "keypoints3d"), "keypoints3d", index, (HY_BODY_JOINTS, 3))
    n = rot6d.shape[0]
    if transl.shape[0] != n or kp.shape[0] != n:
        raise ValidationError(f"HY-Motion output frame counts differ: rot6d {n}, transl "
                              f"{transl.shape[0]}, keypoints3d {kp.shape[0]}", field="output")
    local = Rotation.from_matrix(rot6d_to_matrix(rot6d[:, :HY_BODY_JOINTS]).reshape(-1, 3, 3))
    local_q = local.as_quat().reshape(n, HY_BODY_JOINTS, 4)
    glob = np.empty_like(local_q)
    for j, p in enumerate(SMPL22_PARENTS):
        glob[:, j] = local_q[:, j] if p < 0 else quat.multiply(glob[:, p], local_q[:, j])
    glob /= np.linalg.norm(glob, axis=-1, keepdims=True)
    positions = kp[:, :HY_BODY_JOINTS] + transl[:, None, :]
    shift = _floor_shift(positions)
    positions[..., 1] += shift
    info = dict(meta or {})
    info.setdefault("backend", BACKEND_NAME)
    info.update(fps=float(fps), floor_shift_m=round(float(shift), 6), hy_frames=int(n))
    return Motion(positions, glob, fps, SMPL22_JOINTS, SMPL22_PARENTS, info)


def _floor_shift(positions: np.ndarray) -> float:
    """Vertical shift that puts the lowest foot joint (over the sequence) at its sole height."""
    s = estimate_height(positions, SMPL22_JOINTS) / DEFAULT_HEIGHT_M
    lows = [positions[:, SMPL22_JOINTS.index(j), 1].min() - h * s for j, h in _SOLE_170.items()]
    return -float(min(lows))


# -- availability ------------------------------------------------------------------------
def model_path(path: str | os.PathLike[str] | None = None) -> Path:
    """The checkpoint folder: the argument, else $VSMP_HYMOTION_MODEL, else ckpts/tencent/HY-Motion-1.0."""
    return Path(path or os.environ.get(MODEL_PATH_ENV) or DEFAULT_MODEL_PATH)


def check_available(path: str | os.PathLike[str] | None = None) -> Path:
    """The checkpoint folder when HY-Motion can run here; otherwise a DependencyError saying why."""
    if importlib.util.find_spec("hymotion") is None:
        raise DependencyError("HY-Motion 1.0 (python package 'hymotion') is not installed; "
                              + INSTALL_HINT, field="backend", allowed="--backend procedural")
    try:
        import torch
    except ImportError:
        raise DependencyError("HY-Motion needs PyTorch, which is not installed",
                              field="backend", allowed="--backend procedural") from None
    if not torch.cuda.is_available():
        raise DependencyError("HY-Motion needs a CUDA GPU (26 GB for HY-Motion-1.0, 24 GB for "
                              "the Lite model) and none is available",
                              field="backend", allowed="--backend procedural")
    folder = model_path(path)
    missing = [f for f in ("config.yml", "latest.ckpt") if not (folder / f).is_file()]
    if missing:
        raise DependencyError(
            f"HY-Motion weights not found ({', '.join(missing)} missing in {folder}); download them "
            "with `huggingface-cli download tencent/HY-Motion-1.0 --include 'HY-Motion-1.0/*' "
            f"--local-dir ckpts/tencent` or point ${MODEL_PATH_ENV} at the folder",
            file=folder, field="model_path")
    return folder


class HYMotionBackend:
    """Text-to-motion with HY-Motion 1.0 (GPU, external weights).

    `model_path`: folder with config.yml and latest.ckpt; `cfg_scale`:
    classifier-free guidance; `runtime`: an object with HY-Motion's
    `generate_motion` signature (default: a `T2MRuntime` built on first use);
    `library`: the activity library used to find an SMP's natural duration.
    """

    name = BACKEND_NAME

    def __init__(self, model_path: str | None = None, cfg_scale: float = DEFAULT_CFG_SCALE,
                 library: Any = None, runtime: Any = None, device_ids: list[int] | None = None) -> None:
        self.model_path = model_path
        self.cfg_scale = cfg_scale
        self.library = library
        self.runtime = runtime
        self.device_ids = device_ids

    def generate(self, smp_or_prompt: SMP | str, seed: int, duration_s: float | None = None) -> Motion:
        """One motion for an SMP (verbalized) or a prompt, with HY-Motion seed `seed`."""
        text, smp = self._text(smp_or_prompt)
        requested = duration_s if duration_s is not None else self._natural_duration(smp, seed)
        if not (requested > 0 and np.isfinite(requested)):
            raise ValidationError(f"duration_s must be a positive number of seconds, got {requested}",
                                  field="duration_s")
        duration = float(np.clip(requested, HY_MIN_DURATION_S, HY_MAX_DURATION_S))
        runtime = self._runtime()
        with tempfile.TemporaryDirectory(prefix="hymotion_") as tmp:
            result = runtime.generate_motion(text, seeds_csv=str(int(seed)), duration=duration,
                                             cfg_scale=self.cfg_scale, output_format="dict",
                                             output_dir=tmp)
        output = result[-1] if isinstance(result, tuple) else result
        meta = {
            "backend": BACKEND_NAME, "seed": int(seed), "prompt": text, "cfg_scale": self.cfg_scale,
            "requested_duration_s": float(requested), "duration_s": duration,
            "duration_clipped": bool(duration != requested),
        }
        if smp is not None:
            meta.update(smp_id=smp.smp_id, activity_label=smp.activity_label)
            entry = self._entry(smp)
            if entry is not None:
                meta["activity"] = entry.name
        return motion_from_hymotion(output, 0, HY_FPS, meta)

    # -- helpers -----------------------------------------------------------------
    def _text(self, smp_or_prompt: SMP | str) -> tuple[str, SMP | None]:
        if isinstance(smp_or_prompt, str):
            if not smp_or_prompt.strip():
                raise ValidationError("the prompt is empty", field="prompt")
            return smp_or_prompt.strip(), None
        if not isinstance(smp_or_prompt, SMP):
            raise ValidationError(f"expected an SMP or a prompt string, got {type(smp_or_prompt).__name__}",
                                  field="smp")
        from vsmp_imu.smp.verbalize import verbalize

        return verbalize(smp_or_prompt), smp_or_prompt

    def _library(self) -> Any:
        if self.library is None:
            from vsmp_imu.smp.library import ActivityLibrary

            self.library = ActivityLibrary.load()
        return self.library

    def _entry(self, smp: SMP) -> Any:
        try:
            return self._library().resolve(smp.activity_label)
        except ValidationError:
            return None

    def _natural_duration(self, smp: SMP | None, seed: int) -> float:
        """The procedural plan's natural duration for the SMP's activity (else DEFAULT_DURATION_S)."""
        if smp is None or self._entry(smp) is None:
            return DEFAULT_DURATION_S
        from vsmp_imu.motion.procedural import ProceduralBackend

        try:
            return ProceduralBackend(self._library()).plan(smp, seed).natural_duration_s
        except ValidationError:
            return DEFAULT_DURATION_S

    def _runtime(self) -> Any:
        if self.runtime is not None:
            return self.runtime
        folder = check_available(self.model_path)
        try:
            from hymotion.utils.t2m_runtime import T2MRuntime
        except ImportError as exc:
            raise DependencyError(f"cannot import HY-Motion's runtime ({exc}); " + INSTALL_HINT,
                                  field="backend") from exc
        try:
            self.runtime = T2MRuntime(config_path=str(folder / "config.yml"),
                                      ckpt_name=str(folder / "latest.ckpt"),
                                      device_ids=self.device_ids, disable_prompt_engineering=True)
        except FileNotFoundError as exc:
            raise InputFileError(f"HY-Motion could not load its model: {exc}", file=folder) from exc
        return self.runtime
