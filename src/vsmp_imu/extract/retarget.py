"""MediaPipe landmarks -> an SMPL-22 `Motion` (Y-up, body facing +Z in the rest pose, +X left).

1. Frames without a pose are filled: gaps up to `max_gap_s` by linear
   interpolation of the landmarks, longer ones (and the clip's ends) by
   holding the nearest detected frame; both are marked in `meta`.
2. Landmarks are turned into the Y-up frame (`landmarks.world_to_yup`) and
   low-passed (Butterworth 6 Hz, the paper's measurement filter).
3. Every joint gets a global rotation that maps its rest bone direction
   (from the skeleton's rest offsets) onto the observed one, with the twist
   about the bone taken from a second observed axis:
   - pelvis: hip line (exact) and trunk up (mid-hip -> mid-shoulder);
   - spine3 and the collars: shoulder line and trunk up; spine1 and spine2
     interpolate (slerp at 1/3, 2/3) between pelvis and spine3;
   - head: ear line and face direction (mid-ears -> mid-eyes, taken as
     forward at rest); neck: halfway between spine3 and head;
   - upper arm / thigh: bone direction, twist from the elbow / knee bending
     plane when the joint is bent (>15 deg, fully from 45 deg), else from the
     parent (a pure swing);
   - forearm: a pure hinge swing from the upper arm (pronation is given to
     the hand, as in the SMPL DOF model); hand: wrist -> knuckles direction,
     twist from the across-palm axis (pinky -> index, forward at rest with
     palms down); lower leg: twist from the heel -> toe axis (the rest foot's
     horizontal direction, slightly turned out); foot: ankle ->
     toe direction, twist from the parent.
4. Forward kinematics on `smpl22_skeleton(height_m)`: directions are the
   observed ones, bone lengths the skeleton's.

World landmarks are hip-centred, so the root translation is not observed:
the pelvis is held at the skeleton's standing pelvis height above the
origin (`meta["root"] = "fixed"`). The image-space displacement measured by
`posemeasure` is reported separately.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.extract.landmarks import ESTIMATOR_NAME, LM, PoseTrack, world_to_yup
from vsmp_imu.motion.measure import lowpass
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import (
    DEFAULT_HEIGHT_M,
    SMPL22_JOINTS,
    Skeleton,
    forward_kinematics,
    smpl22_skeleton,
)

MAX_GAP_S = 0.5  # gaps up to this long are interpolated, longer ones held
LOWPASS_HZ = 6.0  # paper appendix "Analysis Parameters": Butterworth 6 Hz
BEND_MIN_DEG, BEND_FULL_DEG = 15.0, 45.0
EPS = 1e-9
# mid-ears -> mid-eyes at rest: forward, ~11 deg up (the eyes sit ~1.5 cm above the ear canals)
FACE_REST = np.array([0.0, np.sin(np.radians(11.0)), np.cos(np.radians(11.0))])
J = {name: i for i, name in enumerate(SMPL22_JOINTS)}


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, EPS)


def _perp(v: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Component of v perpendicular to unit d."""
    return v - np.sum(v * d, axis=-1, keepdims=True) * d


def _frames(primary: np.ndarray, secondary: np.ndarray) -> np.ndarray:
    """Orthonormal frames (..., 3, 3) with columns primary, secondary (orthogonalized), cross."""
    p = _unit(primary)
    s = _unit(_perp(secondary, p))
    return np.stack([p, s, np.cross(p, s)], axis=-1)


def align(d0: np.ndarray, a0: np.ndarray, d: np.ndarray, a: np.ndarray) -> Rotation:
    """Rotations taking rest direction d0 exactly onto d, and rest axis a0 as close to a as possible."""
    f = _frames(d, a)
    f0 = _frames(np.broadcast_to(d0, d.shape), np.broadcast_to(a0, a.shape))
    return Rotation.from_matrix(f @ np.swapaxes(f0, -1, -2))


def swing(u: np.ndarray, v: np.ndarray) -> Rotation:
    """The smallest rotations taking unit vectors u onto v (T, 3)."""
    axis = np.cross(u, v)
    s = np.linalg.norm(axis, axis=-1)
    c = np.clip(np.sum(u * v, axis=-1), -1.0, 1.0)
    angle = np.arctan2(s, c)
    safe = np.where(s[:, None] > EPS, axis / np.maximum(s, EPS)[:, None], _any_perp(u))
    return Rotation.from_rotvec(safe * angle[:, None])


def _any_perp(u: np.ndarray) -> np.ndarray:
    trial = np.where(np.abs(u[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    return _unit(np.cross(u, trial))


def slerp_between(a: Rotation, b: Rotation, f: float) -> Rotation:
    """Per-frame rotation a fraction f of the way from a to b."""
    return a * Rotation.from_rotvec((a.inv() * b).as_rotvec() * f)


# -- gaps -----------------------------------------------------------------------
def fill_gaps(values: np.ndarray, valid: np.ndarray, max_gap: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill invalid frames of `values` (T, ...): interior gaps up to `max_gap` frames
    linearly, the rest by holding the nearest valid frame.

    Returns (filled, interpolated mask, held mask). At least one frame must be valid.
    """
    valid = np.asarray(valid, dtype=bool)
    t = len(valid)
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        raise ValueError("no valid frame to fill from")
    flat = values.reshape(t, -1).astype(float)
    out = flat.copy()
    interp = np.zeros(t, dtype=bool)
    held = np.zeros(t, dtype=bool)
    frames = np.arange(t)
    for col in range(flat.shape[1]):
        out[:, col] = np.interp(frames, idx, flat[idx, col])
    # decide per gap: interpolate (short, interior) or hold (long, or at an end)
    i = 0
    while i < t:
        if valid[i]:
            i += 1
            continue
        j = i
        while j < t and not valid[j]:
            j += 1
        interior = i > 0 and j < t
        if interior and (j - i) <= max_gap:
            interp[i:j] = True
        else:
            held[i:j] = True
            if interior:
                mid = (i + j) // 2  # hold each side up to the middle of the gap
                out[i:mid] = flat[i - 1]
                out[mid:j] = flat[j]
            elif i == 0:
                out[i:j] = flat[j]
            else:
                out[i:j] = flat[i - 1]
        i = j
    return out.reshape(values.shape), interp, held


# -- landmarks -> rotations ---------------------------------------------------------
def _lm(p: np.ndarray, name: str) -> np.ndarray:
    return p[:, LM[name]]


def _mid(p: np.ndarray, a: str, b: str) -> np.ndarray:
    return 0.5 * (_lm(p, a) + _lm(p, b))


def _bend_weight(d: np.ndarray, child: np.ndarray) -> np.ndarray:
    angle = np.degrees(np.arccos(np.clip(np.sum(d * child, axis=-1), -1.0, 1.0)))
    return np.clip((angle - BEND_MIN_DEG) / (BEND_FULL_DEG - BEND_MIN_DEG), 0.0, 1.0)


class _Solver:
    """Global joint rotations from Y-up landmarks p (T, 33, 3) and visibility (T, 33)."""

    def __init__(self, skeleton: Skeleton, p: np.ndarray, vis: np.ndarray) -> None:
        self.sk = skeleton
        self.p = p
        self.vis = vis
        self.rest = skeleton.offsets_world()
        self.g: dict[str, Rotation] = {}

    def rest_dir(self, joint: str, child: str) -> np.ndarray:
        return _unit(self.rest[J[child]] - self.rest[J[joint]])

    def limb(self, joint: str, parent: str, child: str, d: np.ndarray, a_obs: np.ndarray | None,
             weight: np.ndarray | None, a0: np.ndarray) -> None:
        """Bone `joint`->`child` along d; twist from a_obs (weight 0..1) or from the parent."""
        d0 = self.rest_dir(joint, child)
        a0 = _unit(_perp(a0, d0))
        gp = self.g[parent]
        dn = np.linalg.norm(d, axis=-1, keepdims=True)
        d = np.where(dn > EPS, d / np.maximum(dn, EPS), gp.apply(d0))
        fallback = (swing(gp.apply(d0), d) * gp).apply(a0)
        a = fallback
        if a_obs is not None and weight is not None:
            obs = _perp(a_obs, d)
            on = np.linalg.norm(obs, axis=-1)
            w = np.where(on > 1e-4, weight, 0.0)[:, None]
            a = w * _unit(obs) + (1.0 - w) * fallback
        self.g[joint] = align(d0, a0, d, a)

    def solve(self) -> dict[str, Rotation]:
        p, rest = self.p, self.rest
        up_obs = _mid(p, "left_shoulder", "right_shoulder") - _mid(p, "left_hip", "right_hip")
        hips_obs = _lm(p, "left_hip") - _lm(p, "right_hip")
        sh_obs = _lm(p, "left_shoulder") - _lm(p, "right_shoulder")
        rest_up = (0.5 * (rest[J["left_shoulder"]] + rest[J["right_shoulder"]])
                   - 0.5 * (rest[J["left_hip"]] + rest[J["right_hip"]]))
        rest_hips = rest[J["left_hip"]] - rest[J["right_hip"]]
        rest_sh = rest[J["left_shoulder"]] - rest[J["right_shoulder"]]
        g = self.g
        g["pelvis"] = align(_unit(rest_hips), _unit(rest_up), hips_obs, up_obs)
        g["spine3"] = align(_unit(rest_sh), _unit(rest_up), sh_obs, up_obs)
        g["spine1"] = slerp_between(g["pelvis"], g["spine3"], 1.0 / 3.0)
        g["spine2"] = slerp_between(g["pelvis"], g["spine3"], 2.0 / 3.0)
        g["left_collar"] = g["spine3"]
        g["right_collar"] = g["spine3"]
        ears = _lm(p, "left_ear") - _lm(p, "right_ear")
        face = _mid(p, "left_eye", "right_eye") - _mid(p, "left_ear", "right_ear")
        g["head"] = align(np.array([1.0, 0, 0]), FACE_REST, ears, face)
        g["neck"] = slerp_between(g["spine3"], g["head"], 0.5)
        forward = np.array([0.0, 0.0, 1.0])
        for s in ("left", "right"):
            upper = _lm(p, f"{s}_elbow") - _lm(p, f"{s}_shoulder")
            fore = _lm(p, f"{s}_wrist") - _lm(p, f"{s}_elbow")
            palm = _lm(p, f"{s}_index") - _lm(p, f"{s}_pinky")
            hand = _mid(p, f"{s}_index", f"{s}_pinky") - _lm(p, f"{s}_wrist")
            self.limb(f"{s}_shoulder", f"{s}_collar", f"{s}_elbow", upper, fore,
                      _bend_weight(_unit(upper), _unit(fore)), forward)
            self.limb(f"{s}_elbow", f"{s}_shoulder", f"{s}_wrist", fore, None, None, forward)
            d0 = self.rest_dir(f"{s}_elbow", f"{s}_wrist")
            hand_dir = np.where(np.linalg.norm(hand, axis=-1, keepdims=True) > EPS, hand, fore)
            a = _perp(palm, _unit(hand_dir))
            ok = (np.linalg.norm(a, axis=-1) > 1e-4)[:, None]
            a = np.where(ok, a, g[f"{s}_elbow"].apply(_unit(_perp(forward, d0))))
            g[f"{s}_wrist"] = align(d0, _unit(_perp(forward, d0)), hand_dir, a)
            thigh = _lm(p, f"{s}_knee") - _lm(p, f"{s}_hip")
            shank = _lm(p, f"{s}_ankle") - _lm(p, f"{s}_knee")
            foot = _lm(p, f"{s}_foot_index") - _lm(p, f"{s}_heel")
            toe = _lm(p, f"{s}_foot_index") - _lm(p, f"{s}_ankle")
            foot_vis = np.clip((self.vis[:, [LM[f"{s}_heel"], LM[f"{s}_foot_index"]]].mean(axis=1)
                                - 0.3) / 0.4, 0.0, 1.0)
            self.limb(f"{s}_hip", "pelvis", f"{s}_knee", thigh, shank,
                      _bend_weight(_unit(thigh), _unit(shank)), -forward)
            toe_rest = self.rest_dir(f"{s}_ankle", f"{s}_foot") * np.array([1.0, 0.0, 1.0])
            self.limb(f"{s}_knee", f"{s}_hip", f"{s}_ankle", shank, foot, foot_vis, toe_rest)
            self.limb(f"{s}_ankle", f"{s}_knee", f"{s}_foot", toe, None, None, np.array([1.0, 0, 0]))
            g[f"{s}_foot"] = g[f"{s}_ankle"]
        return g


def global_rotations(skeleton: Skeleton, landmarks_yup: np.ndarray, visibility: np.ndarray) -> np.ndarray:
    """(T, 22, 4) global joint rotations (xyzw) from Y-up landmarks (T, 33, 3)."""
    g = _Solver(skeleton, landmarks_yup, visibility).solve()
    return np.stack([g[name].as_quat() for name in SMPL22_JOINTS], axis=1)


def rotations_to_motion(skeleton: Skeleton, glob: np.ndarray, fps: float,
                        meta: dict[str, Any] | None = None) -> Motion:
    """Forward kinematics from global rotations with the root held at standing pelvis height."""
    t = glob.shape[0]
    rots = [Rotation.from_quat(glob[:, j]) for j in range(skeleton.n_joints)]
    local = np.empty_like(glob)
    for j, parent in enumerate(skeleton.parents):
        local[:, j] = (rots[j] if parent < 0 else rots[parent].inv() * rots[j]).as_quat()
    root = np.tile([0.0, skeleton.pelvis_height(), 0.0], (t, 1))
    pos, rot = forward_kinematics(skeleton, local, root)
    return Motion(pos, rot, fps, skeleton.joint_names, skeleton.parents, dict(meta or {}))


def track_to_motion(track: PoseTrack, height_m: float = DEFAULT_HEIGHT_M, max_gap_s: float = MAX_GAP_S,
                    lowpass_hz: float | None = LOWPASS_HZ) -> Motion | None:
    """The SMPL-22 motion of a pose track; None when no frame has a pose (or fewer than 2 frames)."""
    if track.n_frames < 2 or not track.detected.any():
        return None
    max_gap = int(round(max_gap_s * track.fps))
    world, interp, held = fill_gaps(track.world, track.detected, max_gap)
    vis, _, _ = fill_gaps(track.visibility, track.detected, max_gap)
    p = world_to_yup(world)
    if lowpass_hz:
        p = lowpass(p.reshape(track.n_frames, -1), track.fps, cutoff_hz=lowpass_hz).reshape(p.shape)
    skeleton = smpl22_skeleton(height_m)
    glob = global_rotations(skeleton, p, vis)
    meta = {
        "source": "video_pose", "backend": "video_pose", "estimator": ESTIMATOR_NAME,
        "video": track.source.get("path"), "video_sha256": track.source.get("sha256"),
        "frame_indices": [int(i) for i in track.frame_indices],
        "detected": [int(d) for d in track.detected],
        "detected_fraction": round(track.detected_fraction, 6),
        "interpolated_fraction": round(float(interp.mean()), 6),
        "held_fraction": round(float(held.mean()), 6),
        "max_gap_s": max_gap_s, "lowpass_hz": lowpass_hz, "height_m": height_m,
        "root": "fixed", "retarget": "directions observed, lengths from smpl22_skeleton",
    }
    return rotations_to_motion(skeleton, glob, track.fps, meta)
