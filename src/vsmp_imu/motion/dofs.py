"""Anatomical degrees of freedom (DOFs) of the SMPL-22 body and their joint rotations.

The procedural backend animates a body through named anatomical angles in
degrees (``left_elbow_flex``, ``trunk_twist``, ...) instead of raw
quaternions. Conventions (body standing, facing +Z, +X = the body's left,
+Y = up; all zero = the SMPL T-pose except that zero shoulder abduction
means arms hanging down):

- centre DOFs: ``root_pitch`` (+ = whole body tips forward; -90 = lying on
  the back), ``root_yaw`` (+ = turn to the left), ``root_roll`` (+ = lean to
  the left), ``root_dx/dy/dz`` (metres for a 1.70 m body: left, up, forward),
  ``trunk_flex`` (+ = bend forward), ``trunk_lean`` (+ = to the left),
  ``trunk_twist`` (+ = chest turns left), ``neck_flex``, ``head_flex``
  (+ = chin down), ``head_turn`` (+ = look left), ``head_tilt`` (+ = ear to
  the left shoulder), ``pelvis_tilt`` (+ = anterior tilt of the pelvis
  segment alone; the thighs and the upper body keep their orientation).
  Trunk flexion is shared between the lumbar spine and the pelvis
  (lumbopelvic rhythm): the pelvis segment tilts by
  ``pelvis_tilt + PELVIS_FLEX_SHARE * trunk_flex`` while the hips and the
  spine compensate exactly, so only the pelvis segment (and a sensor on it)
  sees the tilt.
- side DOFs, written ``left_<dof>`` / ``right_<dof>`` (or without the side
  prefix for both sides at once): ``collar_elev`` (shrug), ``collar_protract``
  (shoulder forward), ``shoulder_abd`` (arm raised sideways, 90 = horizontal),
  ``shoulder_flex`` (arm raised forward, 90 = horizontal, 180 = overhead),
  ``shoulder_horiz`` (arm swung across the body), ``shoulder_rot`` (internal
  rotation), ``elbow_flex``, ``wrist_flex`` (palm side), ``wrist_dev``
  (radial deviation), ``wrist_rot`` (forearm pronation: turns the
  forearm segment about its long axis, so a wrist-worn sensor turns with it),
  ``hip_flex`` (thigh forward),
  ``hip_abd`` (thigh outwards), ``hip_rot`` (internal rotation), ``knee_flex``,
  ``ankle_flex`` (dorsiflexion, toes up), ``ankle_inv`` (inversion),
  ``toe_flex`` (toes up).

A right-side DOF means the same anatomical movement as its left twin: the
right joint's rotation is the mirror image (x, -y, -z, w) of the left formula.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from vsmp_imu.motion.quat import compose, euler, multiply, multiply_components
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, SMPL22_OFFSETS_170

CENTER_DOFS: tuple[str, ...] = (
    "root_pitch", "root_yaw", "root_roll", "root_dx", "root_dy", "root_dz",
    "trunk_flex", "trunk_lean", "trunk_twist", "neck_flex", "head_flex", "head_turn", "head_tilt",
    "pelvis_tilt",
)
SIDE_DOFS: tuple[str, ...] = (
    "collar_elev", "collar_protract", "shoulder_abd", "shoulder_flex", "shoulder_horiz",
    "shoulder_rot", "elbow_flex", "wrist_flex", "wrist_dev", "wrist_rot", "hip_flex", "hip_abd",
    "hip_rot", "knee_flex", "ankle_flex", "ankle_inv", "toe_flex",
)
SIDES = ("left", "right")
DOF_NAMES: tuple[str, ...] = (
    CENTER_DOFS
    + tuple(f"left_{d}" for d in SIDE_DOFS)
    + tuple(f"right_{d}" for d in SIDE_DOFS)
)
DOF_INDEX = {name: i for i, name in enumerate(DOF_NAMES)}
N_DOFS = len(DOF_NAMES)
TRANSLATION_DOFS = ("root_dx", "root_dy", "root_dz")
# Centre DOFs that change sign in the left-right mirror image.
MIRROR_ODD = ("root_yaw", "root_roll", "root_dx", "trunk_lean", "trunk_twist", "head_turn", "head_tilt")

LEFT_COLUMNS = np.array([DOF_INDEX[f"left_{d}"] for d in SIDE_DOFS])
RIGHT_COLUMNS = np.array([DOF_INDEX[f"right_{d}"] for d in SIDE_DOFS])
SIDE_COLUMNS = {"left": LEFT_COLUMNS, "right": RIGHT_COLUMNS}
ROTATION_COLUMNS = np.array([i for i, n in enumerate(DOF_NAMES) if n not in TRANSLATION_DOFS])

# Anatomical soft limits (degrees) applied after amplitude scaling; the
# limiting function is strictly increasing, so a larger requested amplitude
# never gives a smaller excursion.
LIMITS_DEG: dict[str, tuple[float, float]] = {
    "trunk_flex": (-40, 110), "trunk_lean": (-45, 45), "trunk_twist": (-70, 70), "pelvis_tilt": (-35, 35),
    "neck_flex": (-50, 60), "head_flex": (-50, 60), "head_turn": (-80, 80), "head_tilt": (-40, 40),
    "collar_elev": (-15, 35), "collar_protract": (-25, 30),
    "shoulder_abd": (-30, 185), "shoulder_flex": (-70, 185), "shoulder_horiz": (-60, 140),
    "shoulder_rot": (-90, 100), "elbow_flex": (-5, 150), "wrist_flex": (-75, 85),
    "wrist_dev": (-30, 40), "wrist_rot": (-90, 90),
    "hip_flex": (-35, 135), "hip_abd": (-30, 70), "hip_rot": (-45, 45), "knee_flex": (-5, 155),
    "ankle_flex": (-55, 35), "ankle_inv": (-30, 35), "toe_flex": (-40, 60),
}


def limits_array() -> tuple[np.ndarray, np.ndarray]:
    """(low, high) limit per DOF column; +-inf where a DOF has no limit."""
    low = np.full(N_DOFS, -np.inf)
    high = np.full(N_DOFS, np.inf)
    for name, i in DOF_INDEX.items():
        stem = name.split("_", 1)[1] if name.startswith(SIDES) else name
        if stem in LIMITS_DEG:
            low[i], high[i] = LIMITS_DEG[stem]
    return low, high


def soft_limit(values: np.ndarray, low: np.ndarray, high: np.ndarray, margin: float = 15.0) -> np.ndarray:
    """Squash values (..., N_DOFS) into (low, high) smoothly and monotonically.

    Values more than `margin` inside the range pass unchanged; beyond that
    they approach the limit exponentially (C1, strictly increasing).
    """
    v = np.asarray(values, dtype=float)
    with np.errstate(invalid="ignore"):
        over = np.nan_to_num(np.maximum(v - (high - margin), 0.0))
        under = np.nan_to_num(np.maximum((low + margin) - v, 0.0))
    v = v - over + margin * (1.0 - np.exp(-over / margin))
    return v + under - margin * (1.0 - np.exp(-under / margin))


def expand_pose(pose: Mapping[str, float], *, where: str = "pose") -> dict[str, float]:
    """Canonical DOF names: a side DOF without prefix sets both sides.

    Raises KeyError naming the unknown DOF (callers turn it into a
    ValidationError with the file and field).
    """
    out: dict[str, float] = {}
    for key, value in pose.items():
        if key in DOF_INDEX:
            out[key] = float(value)
        elif key in SIDE_DOFS:
            out[f"left_{key}"] = float(value)
            out[f"right_{key}"] = float(value)
        else:
            raise KeyError(key)
    return out


def is_dof_name(name: str) -> bool:
    """True for a canonical DOF name or a side DOF stem (both sides)."""
    return name in DOF_INDEX or name in SIDE_DOFS


def dof_columns(name: str) -> list[int]:
    """Columns named by a DOF or a side-less stem."""
    if name in DOF_INDEX:
        return [DOF_INDEX[name]]
    if name in SIDE_DOFS:
        return [DOF_INDEX[f"left_{name}"], DOF_INDEX[f"right_{name}"]]
    raise KeyError(name)


def pose_vector(pose: Mapping[str, float], base: np.ndarray | None = None) -> np.ndarray:
    """A (N_DOFS,) vector: `base` (zeros by default) overridden by `pose`."""
    vec = np.zeros(N_DOFS) if base is None else np.array(base, dtype=float, copy=True)
    for key, value in expand_pose(pose).items():
        vec[DOF_INDEX[key]] = value
    return vec


def mirror_dofs(values: np.ndarray) -> np.ndarray:
    """The left-right mirror image of DOF values (..., N_DOFS)."""
    out = np.array(values, dtype=float, copy=True)
    out[..., LEFT_COLUMNS] = values[..., RIGHT_COLUMNS]
    out[..., RIGHT_COLUMNS] = values[..., LEFT_COLUMNS]
    for name in MIRROR_ODD:
        out[..., DOF_INDEX[name]] = -values[..., DOF_INDEX[name]]
    return out


# -- built-in poses (degrees / metres for 1.70 m) ---------------------------------
BUILTIN_POSES: dict[str, dict[str, float]] = {
    "tpose": {"shoulder_abd": 90.0},
    "standing": {"shoulder_abd": 8.0, "elbow_flex": 12.0, "wrist_rot": 0.0, "shoulder_rot": 5.0},
    # on a chair: thighs horizontal, shanks vertical, hands resting on the thighs; the
    # pelvis rolls back (posterior tilt, about 15-20 deg relative to standing)
    "sitting": {"hip_flex": 88.0, "knee_flex": 88.0, "hip_abd": 6.0, "trunk_flex": 4.0, "pelvis_tilt": -20.0,
                "shoulder_abd": 6.0, "shoulder_flex": 18.0, "elbow_flex": 55.0,
                "head_flex": 6.0},
    # on the floor with straight legs
    "sitting_floor": {"hip_flex": 85.0, "knee_flex": 5.0, "trunk_flex": 8.0, "shoulder_abd": 15.0,
                      "shoulder_flex": 15.0, "elbow_flex": 10.0},
    # supine: on the back, face up, arms along the body
    "lying": {"root_pitch": -90.0, "shoulder_abd": 10.0, "elbow_flex": 8.0, "ankle_flex": -25.0,
              "head_flex": 10.0, "hip_abd": 4.0},
    # prone: on the belly, face down
    "lying_prone": {"root_pitch": 90.0, "shoulder_abd": 10.0, "elbow_flex": 8.0,
                    "ankle_flex": -45.0, "head_flex": -25.0},
    "kneeling": {"hip_flex": 0.0, "knee_flex": 90.0, "ankle_flex": -40.0, "shoulder_abd": 8.0,
                 "elbow_flex": 12.0},
}


# -- DOF values -> local joint rotations -------------------------------------------
_J = {name: i for i, name in enumerate(SMPL22_JOINTS)}
_SPINE_WEIGHTS = {"spine1": 0.35, "spine2": 0.35, "spine3": 0.30}
# Share of trunk flexion carried by the pelvis (lumbopelvic rhythm: forward
# bending is roughly half lumbar flexion, half pelvic rotation about the hips).
PELVIS_FLEX_SHARE = 0.5


def _col(values: np.ndarray, name: str) -> np.ndarray:
    return np.radians(values[:, DOF_INDEX[name]])


def _unit(v: np.ndarray) -> np.ndarray:
    return np.asarray(v, dtype=float) / np.linalg.norm(v)


# The forearm's long axis (elbow -> wrist) in the forearm frame, written for the
# left formulas: the right side's axis is its mirror image, so that after
# mirroring it is the right forearm's own bone. Pronation turns the forearm
# about this axis (a watch on the forearm turns with it); the hand is turned
# back by the same twist, so hand orientation and joint positions are those of
# a pronation carried by the wrist alone.
_MIRROR = np.array([-1.0, 1.0, 1.0])
FOREARM_AXIS = {
    "left": _unit(SMPL22_OFFSETS_170[SMPL22_JOINTS.index("left_wrist")]),
    "right": _unit(_MIRROR * SMPL22_OFFSETS_170[SMPL22_JOINTS.index("right_wrist")]),
}


def _twist(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Quaternions (T, 4) of rotations by `angle` (rad) about a unit `axis`."""
    q = np.zeros(angle.shape + (4,))
    q[..., :3] = np.sin(0.5 * angle)[..., None] * axis
    q[..., 3] = np.cos(0.5 * angle)
    return q


_INVERSE = np.array([-1.0, -1.0, -1.0, 1.0])  # conjugate of a unit quaternion


def _mirror_quat(q: np.ndarray) -> np.ndarray:
    out = q.copy()
    out[:, 1] *= -1.0
    out[:, 2] *= -1.0
    return out


def _side_rotations(values: np.ndarray, side: str, pelvis_tilt: np.ndarray) -> dict[str, np.ndarray]:
    """Local quaternions of one side's joints, written with the left formulas.

    The hip flexion absorbs the pelvis tilt so the thigh keeps its orientation.
    """
    def c(stem: str) -> np.ndarray:
        return _col(values, f"{side}_{stem}")

    half_pi = np.pi / 2.0
    pronation = _twist(FOREARM_AXIS[side], c("wrist_rot"))
    quats = {
        "collar": euler("YZ", -c("collar_protract"), c("collar_elev")),
        # horizontal swing, forward flexion, abduction from hanging, then axial twist
        "shoulder": euler("YXZX", -c("shoulder_horiz"), -c("shoulder_flex"), c("shoulder_abd") - half_pi,
                          c("shoulder_rot")),
        # the forearm carries pronation; the wrist undoes it before its own rotation
        "elbow": multiply(euler("Y", -c("elbow_flex")), pronation),
        "wrist": multiply(pronation * _INVERSE, euler("XZY", c("wrist_rot"), -c("wrist_flex"), c("wrist_dev"))),
        "hip": euler("XZY", -c("hip_flex") - pelvis_tilt, c("hip_abd"), -c("hip_rot")),
        "knee": euler("X", c("knee_flex")),
        "ankle": euler("XZ", -c("ankle_flex"), -c("ankle_inv")),
        "foot": euler("X", -c("toe_flex")),
    }
    out = {f"{side}_{k}": q for k, q in quats.items()}
    if side == "right":
        out = {k: _mirror_quat(q) for k, q in out.items()}
    return out


def local_quats_reference(values: np.ndarray) -> np.ndarray:
    """`dofs_to_local_quats` written joint by joint: the formulas, and the reference the fast form
    equals to the bit (tests/motion/test_motion_vectorised.py)."""
    values = np.asarray(values, dtype=float)
    t = values.shape[0]
    out = np.zeros((t, len(SMPL22_JOINTS), 4))
    out[..., 3] = 1.0
    flex, lean, twist = _col(values, "trunk_flex"), _col(values, "trunk_lean"), _col(values, "trunk_twist")
    tilt = _col(values, "pelvis_tilt") + PELVIS_FLEX_SHARE * flex
    # the pelvis segment tilts last; spine1 and the hips undo it first (exact compensation)
    out[:, _J["pelvis"]] = euler("YXZX", _col(values, "root_yaw"), _col(values, "root_pitch"),
                                 -_col(values, "root_roll"), tilt)
    for joint, w in _SPINE_WEIGHTS.items():
        out[:, _J[joint]] = euler("YXZ", w * twist, w * flex, -w * lean)
    out[:, _J["spine1"]] = compose(euler("X", -tilt), out[:, _J["spine1"]])
    turn = _col(values, "head_turn")
    out[:, _J["neck"]] = euler("YX", 0.4 * turn, _col(values, "neck_flex"))
    out[:, _J["head"]] = euler("YXZ", 0.6 * turn, _col(values, "head_flex"), -_col(values, "head_tilt"))
    for side in SIDES:
        for joint, q in _side_rotations(values, side, tilt).items():
            out[:, _J[joint]] = q
    return out


# -- the same rotations, all joints at once ------------------------------------------------
# Each joint rotation above is a chain of principal-axis rotations (`euler`); spine1, the elbows
# and the wrists take one more product. The fast form lists the chains with the operations that
# form their angles, evaluates every angle with one numpy call per kind of operation, and
# multiplies step k of all the chains that have one in one product on component-first arrays
# (4, chains, T). Each element sees the operations of the joint-by-joint form in their order
# (zeros of `axis_angle` included), so the result is equal to the bit. A formula changed above
# changes here too: tests/motion/test_motion_vectorised.py fails until both agree.
def _chains() -> list[tuple[str, str, list[tuple]]]:
    """(name, axes, angles): angle specs ("r", dof) radians, ("neg", dof) negated, ("mul", dof, c)
    c * radians, ("minus", dof, c) radians - c, ("neg_minus_tilt", dof), ("tilt",), ("neg_tilt",)."""
    chains = [
        ("pelvis", "YXZX", [("r", "root_yaw"), ("r", "root_pitch"), ("neg", "root_roll"), ("tilt",)]),
        *((joint, "YXZ", [("mul", "trunk_twist", w), ("mul", "trunk_flex", w), ("mul", "trunk_lean", -w)])
          for joint, w in _SPINE_WEIGHTS.items()),
        ("spine1_tilt", "X", [("neg_tilt",)]),
        ("neck", "YX", [("mul", "head_turn", 0.4), ("r", "neck_flex")]),
        ("head", "YXZ", [("mul", "head_turn", 0.6), ("r", "head_flex"), ("neg", "head_tilt")]),
    ]
    for side in SIDES:
        def d(stem: str, side: str = side) -> str:
            return f"{side}_{stem}"

        chains += [
            (d("collar"), "YZ", [("neg", d("collar_protract")), ("r", d("collar_elev"))]),
            (d("shoulder"), "YXZX", [("neg", d("shoulder_horiz")), ("neg", d("shoulder_flex")),
                                     ("minus", d("shoulder_abd"), np.pi / 2.0), ("r", d("shoulder_rot"))]),
            (d("elbow_flex"), "Y", [("neg", d("elbow_flex"))]),
            (d("wrist_own"), "XZY", [("r", d("wrist_rot")), ("neg", d("wrist_flex")), ("r", d("wrist_dev"))]),
            (d("hip"), "XZY", [("neg_minus_tilt", d("hip_flex")), ("r", d("hip_abd")), ("neg", d("hip_rot"))]),
            (d("knee"), "X", [("r", d("knee_flex"))]),
            (d("ankle"), "XZ", [("neg", d("ankle_flex")), ("neg", d("ankle_inv"))]),
            (d("foot"), "X", [("neg", d("toe_flex"))]),
        ]
    return sorted(chains, key=lambda c: -len(c[1]))  # stable: longest first, so step k is a prefix


class _Plan:
    """The chains' index tables (built once)."""

    def __init__(self) -> None:
        chains = _chains()
        self.chain = {name: i for i, (name, _, _) in enumerate(chains)}
        steps = max(len(axes) for _, axes, _ in chains)
        # angle rows step by step: the rows of step k are a slice, its chains a prefix
        specs: list[tuple] = []
        self.steps: list[tuple[slice, np.ndarray]] = []
        for k in range(steps):
            members = [(axes[k], angles[k]) for _, axes, angles in chains if len(axes) > k]
            self.steps.append((slice(len(specs), len(specs) + len(members)),
                               np.array([_AXIS[a] for a, _ in members])))
            specs += [spec for _, spec in members]
        # the forearm twist (pronation) turns by the wrist's first angle: step 0's row of that chain
        self.pronation = np.array([self.chain[f"{side}_wrist_own"] for side in SIDES])
        self.n_rows = len(specs)
        self.kinds: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        for kind in ("r", "neg", "mul", "minus", "neg_minus_tilt", "tilt", "neg_tilt"):
            rows = [i for i, spec in enumerate(specs) if spec[0] == kind]
            cols = [DOF_INDEX[specs[i][1]] if len(specs[i]) > 1 else -1 for i in rows]
            consts = [specs[i][2] if len(specs[i]) > 2 else 0.0 for i in rows]
            self.kinds[kind] = (np.array(rows, dtype=int), np.array(cols, dtype=int), np.array(consts)[:, None])
        self.forearm_axis = np.array([FOREARM_AXIS[side] for side in SIDES]).T[:, :, None]  # (3, side, 1)
        # the extra products (a * b): spine1 after the tilt's undoing; elbow flexion * pronation;
        # undone pronation * the wrist's own rotation
        self.extra_joints = np.array([_J["spine1"], _J["left_elbow"], _J["right_elbow"], _J["left_wrist"],
                                      _J["right_wrist"]])
        c = self.chain
        self.extra_a = np.array([c["spine1_tilt"], c["left_elbow_flex"], c["right_elbow_flex"]])
        self.extra_b = np.array([c["spine1"], c["left_wrist_own"], c["right_wrist_own"]])
        plain = [name for name in c if name in _J and name != "spine1"]
        self.plain_joints = np.array([_J[name] for name in plain])
        self.plain_chains = np.array([c[name] for name in plain])
        self.right_joints = np.array([i for i, name in enumerate(SMPL22_JOINTS) if name.startswith("right_")])


_AXIS = {"X": 0, "Y": 1, "Z": 2}
_PLAN = _Plan()


def _angles(values: np.ndarray) -> np.ndarray:
    """(rows, T) angles in radians of the plan's rows, each formed as the joint-by-joint form does."""
    plan = _PLAN
    rad = np.radians(values).T  # (N_DOFS, T)
    flex = rad[DOF_INDEX["trunk_flex"]]
    tilt = rad[DOF_INDEX["pelvis_tilt"]] + PELVIS_FLEX_SHARE * flex
    out = np.empty((plan.n_rows, values.shape[0]))
    rows, cols, consts = plan.kinds["r"]
    out[rows] = rad[cols]
    rows, cols, consts = plan.kinds["neg"]
    out[rows] = -rad[cols]
    rows, cols, consts = plan.kinds["mul"]
    out[rows] = consts * rad[cols]
    rows, cols, consts = plan.kinds["minus"]
    out[rows] = rad[cols] - consts
    rows, cols, consts = plan.kinds["neg_minus_tilt"]
    out[rows] = -rad[cols] - tilt
    out[plan.kinds["tilt"][0]] = tilt
    out[plan.kinds["neg_tilt"][0]] = -tilt
    return out


def local_quats_components(values: np.ndarray) -> np.ndarray:
    """Local joint rotations as component-first quaternions (4 xyzw, 22, T) from DOF values
    (T, N_DOFS) in degrees (`dofs_to_local_quats`, transposed)."""
    plan = _PLAN
    values = np.asarray(values, dtype=float)
    half = 0.5 * _angles(values)
    sin, cos = np.sin(half), np.cos(half)
    t = values.shape[0]
    chains = None
    for rows, axes in plan.steps:
        n = len(axes)
        q = np.zeros((4, n, t))  # axis_angle: the angle's axis and w; zeros elsewhere
        q[axes, np.arange(n)] = sin[rows]
        q[3] = cos[rows]
        if chains is None:
            chains = q
        else:
            multiply_components(chains[:, :n], q, out=chains[:, :n])
    pronation = np.empty((4, 2, t))
    pronation[:3] = sin[plan.pronation] * plan.forearm_axis
    pronation[3] = cos[plan.pronation]
    a = np.concatenate([chains[:, plan.extra_a], pronation * _INVERSE[:, None, None]], axis=1)
    b = np.concatenate([chains[:, plan.extra_b[:1]], pronation, chains[:, plan.extra_b[1:]]], axis=1)
    out = np.empty((4, len(SMPL22_JOINTS), t))
    out[:, plan.plain_joints] = chains[:, plan.plain_chains]
    out[:, plan.extra_joints] = multiply_components(a, b)
    out[1:3, plan.right_joints] *= -1.0  # the mirror image (x, -y, -z, w)
    return out


def dofs_to_local_quats(values: np.ndarray) -> np.ndarray:
    """Local joint rotations (T, 22, 4 xyzw) from DOF values (T, N_DOFS) in degrees.

    All joints at once (`local_quats_components`); equal to the bit to `local_quats_reference`.
    """
    return np.ascontiguousarray(local_quats_components(values).transpose(2, 1, 0))
