"""Anatomical movements per joint and plane, with normative ranges of motion.

A `Movement` is one anatomical movement (elbow flexion, forearm pronation,
trunk side bend, a squat, gait...) written on the procedural backend's DOFs
(`motion.dofs`): the DOF values it reaches at medium amplitude, as a fraction
of the joint's normative range of motion where it is a single-joint movement.

Normative ranges of motion (degrees, adults): American Academy of Orthopaedic
Surgeons values as tabulated in Greene & Heckman (eds.), "The Clinical
Measurement of Joint Motion", AAOS, Rosemont IL, 1994 (also Norkin & White,
"Measurement of Joint Motion", 5th ed., 2016, appendix A, AAOS column); the
spine values (thoracolumbar and cervical) are the AAOS 1965 "Joint Motion:
Method of Measuring and Recording" figures given there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

# (joint, movement) -> normative range of motion in degrees (AAOS, see above)
ROM_DEG: dict[tuple[str, str], float] = {
    ("shoulder", "flexion"): 180, ("shoulder", "extension"): 60, ("shoulder", "abduction"): 180,
    ("shoulder", "horizontal_adduction"): 135, ("shoulder", "horizontal_abduction"): 45,
    ("shoulder", "internal_rotation"): 70, ("shoulder", "external_rotation"): 90,
    ("elbow", "flexion"): 150,
    ("forearm", "pronation"): 80, ("forearm", "supination"): 80,
    ("wrist", "flexion"): 80, ("wrist", "extension"): 70,
    ("wrist", "radial_deviation"): 20, ("wrist", "ulnar_deviation"): 30,
    ("hip", "flexion"): 120, ("hip", "extension"): 30, ("hip", "abduction"): 45, ("hip", "adduction"): 30,
    ("hip", "internal_rotation"): 45, ("hip", "external_rotation"): 45,
    ("knee", "flexion"): 135,
    ("ankle", "dorsiflexion"): 20, ("ankle", "plantarflexion"): 50,
    ("ankle", "inversion"): 35, ("ankle", "eversion"): 15,
    ("trunk", "flexion"): 80, ("trunk", "extension"): 25, ("trunk", "lateral_flexion"): 35,
    ("trunk", "rotation"): 45,
    ("neck", "flexion"): 45, ("neck", "extension"): 45, ("neck", "lateral_flexion"): 45,
    ("neck", "rotation"): 60,
}  # fmt: skip

PLANES = ("sagittal", "frontal", "transverse")
ARM_JOINTS = ("shoulder", "elbow", "forearm", "wrist")
LEG_JOINTS = ("hip", "knee", "ankle")
KINDS = ("excursion", "posture", "reset", "gait", "jump", "circle", "swing")


def rom(joint: str, movement: str, fraction: float = 1.0) -> float:
    """`fraction` of the normative range of motion of (joint, movement), in degrees."""
    return round(fraction * ROM_DEG[(joint, movement)], 1)


@dataclass(frozen=True)
class Movement:
    """One anatomical movement on the procedural DOFs.

    `pose`: DOF stem (both sides of a sided movement) or centre DOF -> value
    reached at medium amplitude (degrees; metres for root_d*). `sided`: the
    stems apply to the limbs the primitive names. `kind`: excursion (a pose
    reached and left), posture (a change of support: sit, stand, lie),
    gait (periodic waves, locomotion), jump (a hop), circle (circumduction),
    swing (pendulum: out and back through the start), reset (back to the
    base values of its DOFs: an upright trunk). `joint`/`plane`: where
    it acts, for documentation and the measurement.
    """

    name: str
    joint: str
    plane: str
    pose: dict[str, float]
    sided: bool = True
    kind: str = "excursion"
    limb: str = ""  # arm | leg | none: which body parts choose its sides (default: from the joint)
    posture: str | None = None  # the posture reached (kind posture)
    locomotion: str = "none"
    waves: dict[str, list[tuple[float, float]]] = field(default_factory=dict)
    nominal_s: float = 0.9  # duration at medium tempo of one excursion

    def __hash__(self) -> int:
        return hash(self.name)

    def __post_init__(self) -> None:
        if not self.limb:
            limb = "arm" if self.joint in ARM_JOINTS else "leg" if self.joint in LEG_JOINTS else "none"
            object.__setattr__(self, "limb", limb)


def _m(name: str, joint: str, plane: str, pose: dict[str, float], **kw: object) -> Movement:
    return Movement(name, joint, plane, pose, **kw)  # type: ignore[arg-type]


# Gait waves over one cycle (phase 0 = the legs side by side, the left leg
# about to swing); the right side runs half a cycle behind. Sagittal joint
# angles of level walking, running and stair gait as drawn in the gait
# literature (hip about +25/-10, knee 0-60, ankle +10/-15 for walking). The
# pelvis of walking and stair gait: obliquity (`root_roll`) and transverse
# rotation (`root_yaw`) of about ±5° per stride and a tilt (`root_pitch`) of
# about ±2° with each step (normative gait kinematics, as the library's
# walking recipes; docs/results.md, "The walking pelvis turns").
PELVIS_WAVES: dict[str, list[tuple[float, float]]] = {
    "root_yaw": [(0.25, 5), (0.75, -5)],
    "root_roll": [(0.0, -5), (0.5, 5)],
    "root_pitch": [(0.0, 2), (0.25, -2), (0.5, 2), (0.75, -2)],
}
WALK_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.05, 5), (0.25, -11), (0.35, -6), (0.5, 17), (0.62, 27), (0.75, 25), (0.85, 21)],
    "knee_flex": [(0.15, 5), (0.35, 38), (0.48, 62), (0.65, 22), (0.75, 5), (0.9, 17)],
    "ankle_flex": [(0.15, 9), (0.35, -17), (0.5, 2), (0.65, 2), (0.75, 0), (0.85, -6)],
    "shoulder_flex": [(0.25, 17), (0.75, -13)],
    "elbow_flex": [(0.25, 28), (0.75, 14)],
    "trunk_twist": [(0.25, -3), (0.75, 3)],
    **PELVIS_WAVES,
}
RUN_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.0, 7), (0.15, -10), (0.3, -3), (0.45, 22), (0.6, 36), (0.75, 33), (0.85, 25), (0.93, 15)],
    "knee_flex": [(0.0, 38), (0.15, 20), (0.3, 60), (0.45, 88), (0.6, 70), (0.75, 38), (0.85, 22), (0.93, 30)],
    "ankle_flex": [(0.0, 15), (0.15, -25), (0.3, -10), (0.45, 0), (0.6, 5), (0.75, 5), (0.85, 0), (0.93, 8)],
    "shoulder_flex": [(0.15, 35), (0.65, -25)],
    "elbow_flex": [(0.15, 100), (0.65, 75)],
    "root_dy": [(0.0, 0.0), (0.25, 0.05), (0.5, 0.0), (0.75, 0.05)],
    "trunk_twist": [(0.15, -5), (0.65, 5)],
    "root_yaw": [(0.15, 3), (0.65, -3)],
}
# Stepping in place: the left knee highest at a quarter cycle, the opposite arm forward (marching
# lifts the thigh to about 45 degrees, knee about 70; a jog in place to about 50 / 95, elbows bent as
# in running, with a short flight between footfalls).
STEP_IN_PLACE_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.0, 3), (0.25, 45), (0.5, 3), (0.75, 0)],
    "knee_flex": [(0.0, 5), (0.25, 70), (0.5, 5), (0.75, 3)],
    "ankle_flex": [(0.0, 0), (0.25, -15), (0.5, 0), (0.75, 0)],
    "shoulder_flex": [(0.25, -15), (0.75, 20)],
    "elbow_flex": [(0.25, 25), (0.75, 15)],
}
JOG_IN_PLACE_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.0, 8), (0.25, 50), (0.5, 8), (0.75, -5)],
    "knee_flex": [(0.0, 25), (0.25, 95), (0.5, 25), (0.75, 15)],
    "ankle_flex": [(0.0, -10), (0.25, -25), (0.5, -10), (0.75, -5)],
    "shoulder_flex": [(0.25, -20), (0.75, 30)],
    "elbow_flex": [(0.25, 95), (0.75, 80)],
    "trunk_flex": [(0.0, 6), (0.25, 8), (0.5, 6), (0.75, 8)],
    "root_dy": [(0.0, 0.0), (0.25, 0.04), (0.5, 0.0), (0.75, 0.04)],
}
STAIRS_UP_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.25, 6), (0.4, 18), (0.6, 56), (0.75, 52), (0.95, 34)],
    "knee_flex": [(0.25, 8), (0.45, 92), (0.65, 70), (0.75, 58), (0.95, 38)],
    "ankle_flex": [(0.05, 12), (0.3, -14), (0.5, 10), (0.75, 8)],
    "shoulder_flex": [(0.25, 14), (0.75, -8)],
    "elbow_flex": [(0.25, 26), (0.75, 16)],
    "trunk_twist": [(0.25, -2), (0.75, 2)],
    **PELVIS_WAVES,
}
STAIRS_DOWN_WAVES: dict[str, list[tuple[float, float]]] = {
    "hip_flex": [(0.1, 28), (0.3, 20), (0.5, 8), (0.65, 30), (0.85, 34)],
    "knee_flex": [(0.1, 20), (0.3, 45), (0.5, 80), (0.65, 55), (0.85, 18)],
    "ankle_flex": [(0.1, -20), (0.3, 12), (0.5, 18), (0.7, -10), (0.85, -25)],
    "shoulder_flex": [(0.25, 14), (0.75, -8)],
    "elbow_flex": [(0.25, 24), (0.75, 14)],
    "trunk_twist": [(0.25, -2), (0.75, 2)],
    **PELVIS_WAVES,
}

# Postures (the supports of sit / stand / lie transitions): built-in poses of `motion.dofs`.
POSTURES = ("standing", "sitting", "sitting_floor", "lying", "lying_prone", "kneeling", "plank")
# the plank (push-up position): face down on straight arms under the shoulders
PLANK_POSE: dict[str, float | str] = {
    "like": "lying_prone", "root_pitch": 72, "shoulder_flex": 72, "shoulder_abd": 12, "elbow_flex": 5,
    "wrist_flex": -80, "ankle_flex": 0, "toe_flex": 30, "head_flex": 0}
# Forward shift of the pelvis (m, 1.70 m body) when sitting down onto a seat behind the feet.
SEAT_SHIFT_M = -0.40

MOVEMENTS: dict[str, Movement] = {m.name: m for m in (
    # shoulder
    _m("shoulder_flexion", "shoulder", "sagittal", {"shoulder_flex": rom("shoulder", "flexion", 0.5)}),
    _m("shoulder_flexion_overhead", "shoulder", "sagittal",
       {"shoulder_flex": rom("shoulder", "flexion", 0.9), "elbow_flex": 10}),
    _m("shoulder_extension", "shoulder", "sagittal", {"shoulder_flex": -rom("shoulder", "extension", 0.6)}),
    _m("shoulder_abduction", "shoulder", "frontal", {"shoulder_abd": rom("shoulder", "abduction", 0.5)}),
    _m("shoulder_abduction_overhead", "shoulder", "frontal",
       {"shoulder_abd": rom("shoulder", "abduction", 0.8), "elbow_flex": 10}),
    _m("shoulder_horizontal_adduction", "shoulder", "transverse",
       {"shoulder_flex": rom("shoulder", "flexion", 0.45), "shoulder_horiz": rom("shoulder", "horizontal_adduction", 0.5)}),
    _m("shoulder_horizontal_abduction", "shoulder", "transverse",
       {"shoulder_abd": rom("shoulder", "abduction", 0.5), "shoulder_horiz": -rom("shoulder", "horizontal_abduction", 0.6)}),
    _m("shoulder_internal_rotation", "shoulder", "transverse",
       {"shoulder_rot": rom("shoulder", "internal_rotation", 0.7)}),
    _m("shoulder_external_rotation", "shoulder", "transverse",
       {"shoulder_rot": -rom("shoulder", "external_rotation", 0.5)}),
    _m("shoulder_elevation", "shoulder", "frontal", {"collar_elev": 25}),
    # elbow, forearm, wrist
    _m("elbow_flexion", "elbow", "sagittal", {"elbow_flex": rom("elbow", "flexion", 0.85)}),
    _m("elbow_extension", "elbow", "sagittal", {"elbow_flex": 5}),
    # the elbows bent in a plank: the hands stay on the floor, so the body lowers (a push-up)
    _m("push_up_lower", "elbow", "sagittal", {"elbow_flex": 92, "shoulder_flex": 18, "shoulder_abd": 50,
                                               "root_pitch": 82, "root_dz": 0.03}),
    # placements of the hands that exercises hold (values as the library's recipes set them)
    _m("hands_on_hips", "shoulder", "frontal", {"shoulder_abd": 38, "shoulder_flex": -8, "shoulder_rot": 35,
                                                "elbow_flex": 95, "wrist_rot": 40, "wrist_flex": -20}),
    _m("hands_at_chest", "elbow", "sagittal", {"elbow_flex": 100, "shoulder_flex": 30, "shoulder_abd": 16,
                                               "shoulder_horiz": 32, "wrist_rot": 40}),
    _m("arms_crossed", "shoulder", "transverse", {"shoulder_horiz": 55, "shoulder_flex": 45, "shoulder_abd": 12,
                                                  "shoulder_rot": 30, "elbow_flex": 105, "wrist_rot": 20}),
    # dumbbells at the shoulders before a press overhead: upper arms out and turned out, forearms upright
    _m("press_rack", "shoulder", "frontal", {"shoulder_abd": 82, "shoulder_flex": 15, "shoulder_rot": -80,
                                             "elbow_flex": 95, "wrist_rot": 70}),
    # boxing guard: fists before the chin (a held posture of punches)
    _m("guard", "elbow", "sagittal", {"elbow_flex": 115, "shoulder_flex": 35, "wrist_rot": 45}),
    _m("forearm_pronation", "forearm", "transverse", {"wrist_rot": rom("forearm", "pronation", 0.85)}),
    _m("forearm_supination", "forearm", "transverse", {"wrist_rot": -rom("forearm", "supination", 0.85)}),
    _m("wrist_flexion", "wrist", "sagittal", {"wrist_flex": rom("wrist", "flexion", 0.6)}),
    _m("wrist_extension", "wrist", "sagittal", {"wrist_flex": -rom("wrist", "extension", 0.6)}),
    _m("wrist_radial_deviation", "wrist", "frontal", {"wrist_dev": rom("wrist", "radial_deviation", 0.8)}),
    _m("wrist_ulnar_deviation", "wrist", "frontal", {"wrist_dev": -rom("wrist", "ulnar_deviation", 0.8)}),
    _m("arm_circumduction", "shoulder", "multi",
       {"shoulder_flex": rom("shoulder", "flexion", 0.35), "shoulder_abd": 20}, kind="circle"),
    _m("arm_pendulum_swing", "shoulder", "sagittal",
       {"shoulder_flex": rom("shoulder", "flexion", 0.2)}, kind="swing", nominal_s=0.6),
    # legs
    _m("hip_flexion", "hip", "sagittal", {"hip_flex": rom("hip", "flexion", 0.6), "knee_flex": 70}, limb="leg"),
    _m("hip_extension", "hip", "sagittal", {"hip_flex": -rom("hip", "extension", 0.6)}, limb="leg"),
    _m("hip_abduction", "hip", "frontal", {"hip_abd": rom("hip", "abduction", 0.6)}, limb="leg"),
    _m("knee_flexion", "knee", "sagittal", {"knee_flex": rom("knee", "flexion", 0.65)}, limb="leg"),
    _m("knee_extension", "knee", "sagittal", {"knee_flex": 3}, limb="leg"),
    _m("ankle_plantarflexion", "ankle", "sagittal", {"ankle_flex": -rom("ankle", "plantarflexion", 0.6)},
       limb="leg"),
    _m("ankle_dorsiflexion", "ankle", "sagittal", {"ankle_flex": rom("ankle", "dorsiflexion", 0.8)}, limb="leg"),
    _m("leg_kick", "hip", "sagittal", {"hip_flex": rom("hip", "flexion", 0.5), "knee_flex": 10,
                                       "ankle_flex": -20}, limb="leg", nominal_s=0.5),
    # trunk and neck
    _m("trunk_flexion", "trunk", "sagittal", {"trunk_flex": rom("trunk", "flexion", 0.6)}, sided=False),
    _m("trunk_extension", "trunk", "sagittal", {"trunk_flex": -rom("trunk", "extension", 0.6)}, sided=False),
    _m("trunk_side_bend", "trunk", "frontal", {"trunk_lean": rom("trunk", "lateral_flexion", 0.7)},
       sided=False),
    _m("trunk_rotation", "trunk", "transverse", {"trunk_twist": rom("trunk", "rotation", 0.8)}, sided=False),
    _m("neck_flexion", "neck", "sagittal", {"head_flex": rom("neck", "flexion", 0.6)}, sided=False),
    _m("neck_rotation", "neck", "transverse", {"head_turn": rom("neck", "rotation", 0.6)}, sided=False),
    # whole body
    _m("squat", "hip", "sagittal", {"hip_flex": 92, "knee_flex": 105, "ankle_flex": 24, "trunk_flex": 32,
                                     "root_dz": -0.27}, sided=False, limb="leg", nominal_s=1.0),
    _m("knee_bend", "knee", "sagittal", {"hip_flex": 25, "knee_flex": 40, "ankle_flex": 15, "trunk_flex": 8,
                                          "root_dz": -0.06}, sided=False, limb="leg", nominal_s=0.7),
    _m("lunge", "hip", "sagittal", {"hip_flex": 80, "knee_flex": 90, "ankle_flex": 15}, limb="leg",
       nominal_s=1.2),
    _m("hip_hinge", "hip", "sagittal", {"trunk_flex": 20, "root_pitch": 35, "hip_flex": -15, "knee_flex": 15},
       sided=False, nominal_s=1.0),
    _m("turn", "body", "transverse", {"root_yaw": 90}, sided=False, nominal_s=1.2),
    # seated, lean the whole body back on the hands before lying down: the pelvis rolls back with the
    # trunk, the hips open a little and the hands reach back for the bed (the library's sit-to-lie pose)
    _m("recline", "body", "sagittal", {"root_pitch": -45, "hip_flex": 80, "knee_flex": 70, "trunk_flex": 0,
                                        "shoulder_abd": 25, "elbow_flex": 20, "root_dz": -0.15},
       sided=False, nominal_s=1.2),
    _m("jump", "body", "sagittal", {"root_dy": 0.09}, sided=False, kind="jump", limb="leg", nominal_s=0.5),
    _m("walk", "hip", "sagittal", {}, sided=False, kind="gait", limb="leg", locomotion="forward",
       waves=WALK_WAVES, nominal_s=0.53),
    _m("run", "hip", "sagittal", {"trunk_flex": 8, "elbow_flex": 85, "hip_flex": 16, "knee_flex": 55},
       sided=False, kind="gait", limb="leg", locomotion="forward", waves=RUN_WAVES, nominal_s=0.4),
    _m("step_in_place", "hip", "sagittal", {}, sided=False, kind="gait", limb="leg", waves=STEP_IN_PLACE_WAVES,
       nominal_s=0.55),
    _m("jog_in_place", "hip", "sagittal", {"trunk_flex": 6, "elbow_flex": 85}, sided=False, kind="gait",
       limb="leg", waves=JOG_IN_PLACE_WAVES, nominal_s=0.36),
    _m("stairs_up", "hip", "sagittal", {"trunk_flex": 8}, sided=False, kind="gait", limb="leg",
       locomotion="stairs_up", waves=STAIRS_UP_WAVES, nominal_s=0.6),
    _m("stairs_down", "knee", "sagittal", {}, sided=False, kind="gait", limb="leg",
       locomotion="stairs_down", waves=STAIRS_DOWN_WAVES, nominal_s=0.6),
    _m("sit_down", "hip", "sagittal", {}, sided=False, kind="posture", posture="sitting", nominal_s=1.5),
    _m("sit_down_floor", "hip", "sagittal", {}, sided=False, kind="posture", posture="sitting_floor",
       nominal_s=1.8),
    _m("stand_up", "hip", "sagittal", {}, sided=False, kind="posture", posture="standing", nominal_s=1.3),
    _m("lie_down", "body", "sagittal", {}, sided=False, kind="posture", posture="lying", nominal_s=1.2),
    _m("lie_prone", "body", "sagittal", {}, sided=False, kind="posture", posture="lying_prone", nominal_s=1.8),
    _m("kneel", "knee", "sagittal", {}, sided=False, kind="posture", posture="kneeling", nominal_s=1.5),
    _m("plank", "body", "sagittal", {}, sided=False, kind="posture", posture="plank", nominal_s=1.8),
    # back to the base values of their DOFs: upright trunk, straight legs
    _m("trunk_upright", "trunk", "sagittal", {"trunk_flex": 0, "trunk_lean": 0, "trunk_twist": 0}, sided=False,
       kind="reset"),
    _m("leg_straighten", "knee", "sagittal", {"hip_flex": 0, "knee_flex": 0, "ankle_flex": 0, "root_dz": 0,
                                               "trunk_flex": 0}, sided=False, kind="reset", limb="leg"),
)}

# DOF stem -> (joint, plane) it moves, for naming the joints and planes of a compiled motion
DOF_JOINT_PLANE: dict[str, tuple[str, str]] = {
    "shoulder_flex": ("shoulder", "sagittal"), "shoulder_abd": ("shoulder", "frontal"),
    "shoulder_horiz": ("shoulder", "transverse"), "shoulder_rot": ("shoulder", "transverse"),
    "collar_elev": ("shoulder", "frontal"), "collar_protract": ("shoulder", "transverse"),
    "elbow_flex": ("elbow", "sagittal"), "wrist_rot": ("forearm", "transverse"),
    "wrist_flex": ("wrist", "sagittal"), "wrist_dev": ("wrist", "frontal"),
    "hip_flex": ("hip", "sagittal"), "hip_abd": ("hip", "frontal"), "hip_rot": ("hip", "transverse"),
    "knee_flex": ("knee", "sagittal"), "ankle_flex": ("ankle", "sagittal"), "ankle_inv": ("ankle", "frontal"),
    "toe_flex": ("ankle", "sagittal"),
    "trunk_flex": ("trunk", "sagittal"), "trunk_lean": ("trunk", "frontal"), "trunk_twist": ("trunk", "transverse"),
    "pelvis_tilt": ("trunk", "sagittal"),
    "neck_flex": ("neck", "sagittal"), "head_flex": ("neck", "sagittal"), "head_turn": ("neck", "transverse"),
    "head_tilt": ("neck", "frontal"),
    "root_pitch": ("body", "sagittal"), "root_roll": ("body", "frontal"), "root_yaw": ("body", "transverse"),
}  # fmt: skip

# DOF stem -> the SMPL-22 joint (without side) whose rotation it drives
DOF_SKELETON_JOINT: dict[str, str] = {
    "shoulder_flex": "shoulder", "shoulder_abd": "shoulder", "shoulder_horiz": "shoulder",
    "shoulder_rot": "shoulder", "collar_elev": "collar", "collar_protract": "collar",
    "elbow_flex": "elbow", "wrist_rot": "elbow", "wrist_flex": "wrist", "wrist_dev": "wrist",
    "hip_flex": "hip", "hip_abd": "hip", "hip_rot": "hip", "knee_flex": "knee", "ankle_flex": "ankle",
    "ankle_inv": "ankle", "toe_flex": "foot",
}  # fmt: skip


# movements that undo one another ("swing the fist forward", then "draw the fist back"): a primitive
# made only of the second undoes one made of the first, as a return would
ANTAGONISTS: frozenset[tuple[str, str]] = frozenset({
    ("shoulder_flexion", "shoulder_extension"), ("shoulder_horizontal_adduction", "shoulder_horizontal_abduction"),
    ("shoulder_internal_rotation", "shoulder_external_rotation"), ("elbow_flexion", "elbow_extension"),
    ("forearm_pronation", "forearm_supination"), ("wrist_flexion", "wrist_extension"),
    ("wrist_radial_deviation", "wrist_ulnar_deviation"), ("hip_flexion", "hip_extension"),
    ("knee_flexion", "knee_extension"), ("ankle_plantarflexion", "ankle_dorsiflexion"),
    ("trunk_flexion", "trunk_extension"), ("trunk_flexion", "trunk_upright"),
    ("squat", "stand_up"), ("squat", "leg_straighten"), ("knee_bend", "stand_up"), ("knee_bend", "leg_straighten"),
    ("lunge", "stand_up"), ("lunge", "leg_straighten"), ("sit_down", "stand_up"),
})


def undoes(first: tuple[str, ...], second: tuple[str, ...]) -> bool:
    """Every movement of `second` is the antagonist of one of `first` (named in ANTAGONISTS either way)."""
    return bool(first and second) and all(
        any((a, b) in ANTAGONISTS or (b, a) in ANTAGONISTS for a in first) for b in second)
