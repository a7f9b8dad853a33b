"""BVH export (and a small reader) for motions, e.g. to open them in Blender.

The hierarchy comes from the motion's joint names and parents. Each joint's
OFFSET is its bone vector expressed in the parent joint's frame (the mean
over frames of R_parent^T (p_joint - p_parent)), so the rest pose is the
skeleton's zero pose (the T-pose for SMPL-22). The root has 6 channels
(Xposition Yposition Zposition Zrotation Xrotation Yrotation), every other
joint 3 rotation channels (Zrotation Xrotation Yrotation): the local rotation
R_parent^T R_joint as intrinsic Z-X-Y Euler angles in degrees. Leaf joints
get an End Site continuing their bone. Units are metres unless `scale` says
otherwise (Blender's importer has a scale option; 100 gives centimetres).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.io import read_text, write_text
from vsmp_imu.motion.motion import Motion

EULER_ORDER = "ZXY"  # channel order Zrotation Xrotation Yrotation (intrinsic)
END_SITE_FRACTION = 0.4  # End Site length / the leaf's own bone length
END_SITE_MIN_M = 0.05
MIN_SCALE, MAX_SCALE = 0.01, 1000.0  # below, 6 decimals lose the bones; 1000 gives millimetres


def _offsets(motion: Motion) -> np.ndarray:
    """(J, 3) bone vectors in the parent's frame (root: zeros)."""
    out = np.zeros((motion.n_joints, 3))
    for j, p in enumerate(motion.parents):
        if p < 0:
            continue
        rel = motion.positions[:, j] - motion.positions[:, p]
        out[j] = Rotation.from_quat(motion.rotations[:, p]).inv().apply(rel).mean(axis=0)
    return out


def _local_rotations(motion: Motion) -> list[Rotation]:
    out = []
    for j, p in enumerate(motion.parents):
        glob = Rotation.from_quat(motion.rotations[:, j])
        out.append(glob if p < 0 else Rotation.from_quat(motion.rotations[:, p]).inv() * glob)
    return out


def _end_site(motion: Motion, j: int, offsets: np.ndarray) -> np.ndarray:
    """An End Site offset in the leaf joint's frame, along its own bone."""
    bone = offsets[j]
    length = max(END_SITE_FRACTION * float(np.linalg.norm(bone)), END_SITE_MIN_M)
    direction = bone / max(np.linalg.norm(bone), 1e-9)
    # The bone is expressed in the parent's frame; at rest the leaf's frame equals it.
    return direction * length


def check_scale(scale: float) -> None:
    if not MIN_SCALE <= scale <= MAX_SCALE:  # NaN fails too
        raise ValidationError(f"{scale:g} is not a usable unit scale", field="scale",
                              allowed=f"{MIN_SCALE:g}..{MAX_SCALE:g} (1 = metres, 100 = centimetres)")


# Words a BVH reader takes for structure wherever they stand (Blender's importer reads
# "JOINT MOTION" as the end of the hierarchy); a joint name may be none of them.
BVH_KEYWORDS = ("HIERARCHY", "ROOT", "JOINT", "End", "Site", "OFFSET", "CHANNELS", "MOTION", "Frames:",
                "Frame", "Time:")
_BVH_NAME_ALLOWED = ("joint names without braces, quotes or control characters that are not a BVH "
                     "keyword (" + ", ".join(BVH_KEYWORDS) + ")")


def _check_joint_names(names: tuple[str, ...]) -> None:
    """Refuse a joint name that would change the BVH's structure: a brace opens or closes a
    block, a keyword starts one; a control character is not text a reader expects."""
    for j, name in enumerate(names):
        bad = [c for c in name if c in '{}"' or not c.isprintable()]
        if bad or name in BVH_KEYWORDS:
            what = f"has {bad[0]!r}" if bad else "is a BVH keyword"
            raise ValidationError(f"joint {j}'s name {name!r} {what}, so the BVH would not read back",
                                  field="joint_names", allowed=_BVH_NAME_ALLOWED)


def bvh_text(motion: Motion, scale: float = 1.0) -> str:
    """The BVH file content of a motion."""
    check_scale(scale)
    if not motion.is_finite():
        raise ValidationError("the motion has non-finite positions or rotations", field="positions")
    children: dict[int, list[int]] = {j: [] for j in range(motion.n_joints)}
    roots = []
    for j, p in enumerate(motion.parents):
        (roots if p < 0 else children[p]).append(j)
    if len(roots) != 1:
        raise ValidationError(f"a BVH needs exactly one root joint, the motion has {len(roots)}",
                              field="parents")
    _check_joint_names(motion.joint_names)
    offsets = _offsets(motion) * scale
    lines = ["HIERARCHY"]
    order: list[int] = []
    # depth first, with a stack of its own: a skeleton may chain thousands of joints, deeper
    # than Python's recursion goes
    todo: list[tuple[int, int] | str] = [(roots[0], 0)]
    while todo:
        item = todo.pop()
        if isinstance(item, str):  # a block's closing brace, once its children are written
            lines.append(item)
            continue
        j, depth = item
        pad = "  " * depth
        kind = "ROOT" if motion.parents[j] < 0 else "JOINT"
        lines.append(f"{pad}{kind} {motion.joint_names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offsets[j][0]:.6f} {offsets[j][1]:.6f} {offsets[j][2]:.6f}")
        if kind == "ROOT":
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
        else:
            lines.append(f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")
        order.append(j)
        if not children[j]:
            end = _end_site(motion, j, offsets)
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
            lines.append(f"{pad}  }}")
        todo.append(f"{pad}}}")
        todo.extend((c, depth + 1) for c in reversed(children[j]))
    local = _local_rotations(motion)
    eulers = np.stack([local[j].as_euler(EULER_ORDER, degrees=True) for j in order], axis=1)
    root_pos = motion.positions[:, roots[0]] * scale
    frames = np.concatenate([root_pos, eulers.reshape(motion.n_frames, -1)], axis=1)
    if not (np.isfinite(offsets).all() and np.isfinite(frames).all()):  # e.g. an overflow
        raise ValidationError("the BVH values would not be finite", field="positions")
    lines.append("MOTION")
    lines.append(f"Frames: {motion.n_frames}")
    lines.append(f"Frame Time: {1.0 / motion.fps:.8f}")
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in frames)
    return "\n".join(lines) + "\n" + body + "\n"


def write_bvh(motion: Motion, path: str | Path, scale: float = 1.0) -> Path:
    """Write a motion as a BVH file (atomically)."""
    return write_text(path, bvh_text(motion, scale))


@dataclass
class BVH:
    """A parsed BVH: hierarchy, channels and frame values."""

    joint_names: list[str]
    parents: list[int]
    offsets: np.ndarray  # (J, 3)
    channels: list[list[str]]  # per joint
    frames: np.ndarray  # (T, total channels)
    frame_time_s: float

    def positions(self) -> np.ndarray:
        """Joint positions (T, J, 3) by forward kinematics of the channels."""
        t = self.frames.shape[0]
        pos = np.zeros((t, len(self.joint_names), 3))
        glob: list[Rotation] = []
        col = 0
        for j, chans in enumerate(self.channels):
            values = self.frames[:, col: col + len(chans)]
            col += len(chans)
            trans = np.zeros((t, 3))
            rot_names, rot_vals = "", []
            for name, v in zip(chans, values.T, strict=True):
                if name.endswith("position"):
                    trans[:, "XYZ".index(name[0])] = v
                else:
                    rot_names += name[0]
                    rot_vals.append(v)
            rot = (Rotation.from_euler(rot_names, np.stack(rot_vals, axis=1), degrees=True)
                   if rot_names else Rotation.identity(t))
            p = self.parents[j]
            if p < 0:
                pos[:, j] = trans + self.offsets[j]
                glob.append(rot)
            else:
                pos[:, j] = pos[:, p] + glob[p].apply(self.offsets[j])
                glob.append(glob[p] * rot)
        return pos


def read_bvh(path: str | Path) -> BVH:
    """Parse a BVH file written by `write_bvh` (or a similar simple one)."""
    text = read_text(path)
    tokens = re.findall(r"\S+", text.replace("{", " { ").replace("}", " } "))
    try:
        return _parse(tokens)
    except (ValueError, IndexError, KeyError) as exc:
        raise InputFileError(f"not a readable BVH file ({exc})", file=path) from exc


def _parse(tokens: list[str]) -> BVH:
    i = tokens.index("HIERARCHY") + 1
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    stack: list[int] = []
    last = -1
    while tokens[i] != "MOTION":
        tok = tokens[i]
        if tok in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            offsets.append([0.0, 0.0, 0.0])
            channels.append([])
            last = len(names) - 1
            i += 2
        elif tok == "End":
            depth = 0
            i += 2  # "End Site"
            while True:  # skip the End Site block
                if tokens[i] == "{":
                    depth += 1
                elif tokens[i] == "}":
                    depth -= 1
                    if depth == 0:
                        i += 1
                        break
                i += 1
        elif tok == "{":
            stack.append(last)
            i += 1
        elif tok == "}":
            stack.pop()
            i += 1
        elif tok == "OFFSET":
            offsets[last] = [float(tokens[i + 1]), float(tokens[i + 2]), float(tokens[i + 3])]
            i += 4
        elif tok == "CHANNELS":
            n = int(tokens[i + 1])
            channels[last] = tokens[i + 2: i + 2 + n]
            i += 2 + n
        else:
            raise ValueError(f"unexpected token {tok!r}")
    i += 1
    n_frames = int(tokens[i + 1])
    frame_time = float(tokens[i + 4])
    values = np.array([float(v) for v in tokens[i + 5:]])
    width = sum(len(c) for c in channels)
    if values.size != n_frames * width:
        raise ValueError(f"{values.size} values for {n_frames} frames x {width} channels")
    return BVH(names, parents, np.array(offsets), channels, values.reshape(n_frames, width), frame_time)
