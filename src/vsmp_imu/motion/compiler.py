"""SMP -> parametric motion: compile an SMP into a procedural recipe, no hand keyframes.

`compile_recipe(smp)` reads every primitive with the lexicon
(`motion.lexicon`), turns the movements it names into target poses on the
procedural DOFs (`motion.anatomy`, normative ranges of motion), and writes a
`Recipe` (the same type as a library `procedural:` section), which the
procedural backend then times and realizes exactly as a hand-written one:
order and relative durations of the primitives, repetitions, tempo,
amplitude, dominant side, symmetry and displacement all go through the same
controls (`motion.procedural`).

How a sequence becomes keyframes:

- the first primitive (or the contacts: chair, bed, bicycle...) sets the start
  posture; movements held meanwhile ("keeping the arms extended", "while bent
  forward") join the base pose;
- an outward primitive (curl up, raise the arms, squat down) reaches its
  movements' targets and remembers where it started; a returning one (lower,
  straighten back, return, uncross) goes back there; "... and back" goes out
  and comes back within the primitive; a primitive naming no movement holds;
- sit / stand / lie transitions reach their posture (the seat behind the
  feet, via sitting between standing and lying); a single change of posture
  flows: its primitives share its time and the body passes from one to the
  next without stopping (`pass` keys);
- gait, running and stairs drive periodic waves and locomotion; jumps add a
  hop; circles trace the arm around; alternating left / right primitives each
  go out and back;
- a repeated cycle is the sequence without its set-up and its final return
  (raise the guard ... lower the guard), and always ends where it started.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.motion.anatomy import MOVEMENTS, PLANK_POSE, SEAT_SHIFT_M, Movement, undoes
from vsmp_imu.motion.dofs import (
    BUILTIN_POSES,
    DOF_INDEX,
    DOF_NAMES,
    N_DOFS,
    SIDE_DOFS,
    local_quats_components,
    pose_vector,
)
from vsmp_imu.motion.lexicon import Reading, normalize_text, read_primitive
from vsmp_imu.motion.quat import forward_kinematics_components
from vsmp_imu.motion.recipe import Recipe, parse_recipe
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M, smpl22_skeleton
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.bodyparts import normalize_body_part, side_of
from vsmp_imu.smp.schema import SMP, STRUCTURAL_NAMES, UNKNOWN

STRUCTURAL = STRUCTURAL_NAMES  # sequence words that name no movement
SEAT_WORDS = ("chair", "seat", "bench", "sofa", "couch", "stool", "wheelchair", "car seat", "saddle", "bicycle",
              "bike", "desk")
HOLD_S, STATIC_HOLD_S, RETURN_S = 0.5, 3.0, 0.9
LIE_SHIFT_M = -0.45  # the pelvis slides back along a bed when lying down from its edge (1.70 m body)
CIRCLE_DEG = 25.0
HOP_CROUCH = {"knee_flex": 30.0, "hip_flex": 20.0, "ankle_flex": 15.0}
CHANGE_DEG = 1.0  # a DOF that moves less than this is "still" (cycle closure, principal joints)
PRINCIPAL_MIN_DEG = 15.0
# The fastest joint's mean speed along its path between two keys, at medium tempo: at fast tempo
# (x1.5) and large amplitude (x1.4) the minimum-jerk peak (x1.875) stays under the quality filter's
# 0.20 x height per frame at 30 fps (10.2 m/s for 1.70 m), with SPEED_SPARE for what the product
# misses (measured on the library: a throw's release grows 1.9x at large amplitude, not 1.4x, as the
# wind-up and the release move apart; other seeds' bodies).
SPEED_SPARE = 0.65
MAX_MEAN_SPEED_M_S = 0.20 * DEFAULT_HEIGHT_M * 30.0 * SPEED_SPARE / (1.875 * 1.5 * 1.4)
PATH_SAMPLES = 8  # poses per key interval along which the joints' paths are measured
_ARM_PARTS = ("upper_arm", "forearm", "hand", "shoulder")
SHOULDER_AIM = ("shoulder_flex", "shoulder_abd", "shoulder_horiz")  # where the upper arm points
_ARM_STEMS = ("shoulder_abd", "shoulder_flex", "shoulder_horiz", "shoulder_rot", "elbow_flex", "wrist_rot", "wrist_flex")
WEIGHT_WORDS = ("dumbbell", "kettlebell", "barbell", "weight", "plate")
_ON_THE_LAP = re.compile(r"\bon the (thighs?|knees?|lap)\b|\bin the lap\b")
_LEG_PARTS = ("thigh", "lower_leg", "foot")
# the pelvis path of a walking gait (recipe `pelvis`), as the library's walking and stairs set it;
# running keeps the path its feet imply (its pelvis is lowest at mid-stance)
STAIRS_PELVIS = {"rise_m": 0.07, "speed_fluctuation": 0.5}
WALKING_PELVIS = {"walk": {}, "stairs_up": STAIRS_PELVIS, "stairs_down": STAIRS_PELVIS}
_POSTURE_LIFT = ("hip_flex", "knee_flex", "ankle_flex", "root_dz", "root_pitch", "root_dy")
_YAW, _TRUNK, _DZ = DOF_INDEX["root_yaw"], DOF_INDEX["trunk_flex"], DOF_INDEX["root_dz"]
_PELVIS = DOF_INDEX["pelvis_tilt"]
_BODY = smpl22_skeleton()
_ROOT = [DOF_INDEX[name] for name in ("root_dx", "root_dy", "root_dz")]
_CM = np.where([n.startswith("root_d") for n in DOF_NAMES], 100.0, 1.0)  # root travel: a centimetre counts as a degree


@dataclass
class Step:
    """One primitive of the sequence, as compiled."""

    name: str
    reading: Reading
    parts: tuple[str, ...]
    action: str = "hold"  # hold | go | return | back | gait
    keys: list[tuple[float, np.ndarray, str]] = field(default_factory=list)
    duration_s: float = HOLD_S
    movements: tuple[Movement, ...] = ()
    start: np.ndarray | None = None  # the pose the primitive starts from
    changes_posture: bool = False  # goes from one posture to another (sits down, lies down, gets up)


@dataclass(frozen=True)
class CompiledEntry:
    """A library-entry stand-in for a compiled SMP (what the procedural planner reads)."""

    name: str
    smp: SMP
    path: Path = Path()
    central_primitive: str | None = None
    compiled: bool = True
    extras: dict[str, Any] = field(default_factory=dict)


# -- public ----------------------------------------------------------------------------
def compile_recipe(smp: SMP) -> Recipe:
    """The procedural recipe of `smp`, compiled from its primitives (cached by content)."""
    return _compile_cached(smp.canonical_json())


@functools.lru_cache(maxsize=256)
def _compile_cached(text: str) -> Recipe:
    import json

    smp = SMP.model_validate(json.loads(text))
    return parse_recipe(compile_recipe_data(smp))


def compile_recipe_data(smp: SMP) -> dict[str, Any]:
    """The `procedural:` mapping compiled from `smp` (validated by `compile_recipe`)."""
    steps = _steps(smp)
    posture = _start_posture(smp, steps)
    base = _posture_vector(posture, 0.0)
    if posture == "sitting" and _weights_hang(smp):  # dumbbells hang at the sides, not in the lap
        base = pose_vector({stem: BUILTIN_POSES["standing"].get(stem, 0.0) for stem in _ARM_STEMS}, base)
    for step in steps:
        for m in step.reading.context:
            base = _apply(base, [MOVEMENTS[m]], step, smp, 0)
    if steps and _sets_start(steps[0]):
        base = _apply(base, [MOVEMENTS[m] for m in steps[0].reading.movements
                             if MOVEMENTS[m].kind == "excursion"], steps[0], smp, 0)
        steps[0].action = "hold"
    periodic = _periodic(smp, steps)
    if periodic:
        cycle = _cycle_span(steps)[1]
        held = _held_through_cycle(steps, cycle, smp)  # none unless the cycle has two primitives or more
        if held:  # on the sides and in the direction its cycle's primitives name
            base = _apply(base, held, steps[cycle[0]], smp, 0)
    first = next((s for s in steps if s.action in ("go", "back")), None)
    if first is not None and first.reading.start:  # "from the shoulders": the set starts there
        base = _apply(base, [MOVEMENTS[m] for m in first.reading.start], first, smp, 0)
    gait = [s for s in steps if s.action == "gait"]
    for step in gait[:1]:
        base = pose_vector({k: v for m in step.movements if m.kind == "gait" for k, v in m.pose.items()}, base)
    lead, cycle, _ = _cycle_span(steps) if periodic else ([], list(range(len(steps))), [])
    _keyframes(steps, base, posture, smp, cycle if periodic else [])
    _turn_through_recline(steps)
    _durations(steps, smp)
    _flow(steps, smp)
    kind = "periodic" if periodic else ("static" if _static(smp, steps) else "discrete")
    data: dict[str, Any] = {
        "kind": kind,
        "side": _authored_side(steps, base),
        "base_pose": _pose_dict(base),
        "poses": {},
        "primitives": {},
        "rest_s": 0.0 if (kind == "static" or (periodic and smp.repetition_count() is None)) else 0.3,
    }
    for i, step in enumerate(steps):
        keys = []
        for at, vec, ease in step.keys:
            pname = f"k{i}_{len(keys)}"
            data["poses"][pname] = _pose_dict(vec)
            keys.append([at, pname, ease])
        data["primitives"].setdefault(step.name, {"duration_s": round(step.duration_s, 4), "keys": keys})
    if periodic:
        cyc = [steps[i].name for i in cycle]
        data["cycle"] = {"primitives": list(dict.fromkeys(cyc)), "ramp": 0.0 if gait else 0.25}
        if gait:
            data["cycle"].update(_gait_waves(gait))
        if smp.repetition_count() is None:
            data["continuous"] = True
    elif kind == "static":
        data["continuous"] = True
    loco = _gait_move(gait).locomotion if gait else "none"
    data["locomotion"] = loco
    if loco == "stairs_up":
        data["stair_swing"] = (0.5, 0.7)
    if gait and (walk := _gait_move(gait).name) in WALKING_PELVIS:
        data["pelvis"] = dict(WALKING_PELVIS[walk])
        if loco.startswith("stairs"):
            data["turns"] = {}  # a stairwell's flights and landings, as the library's stairs
    joints = _principal_joints(data, base, steps)
    data["principal_joints"] = joints
    data["symmetry_joints"] = _paired(joints)
    data["amplitude_exempt"] = list(_POSTURE_LIFT) if _changes_posture(steps) else []
    if data["side"] in ("left", "right"):
        data["asymmetry"] = {"lag_s": 0.0, "imbalance": 1.0}
    return data


def compiled_entry(smp: SMP, name: str | None = None, path: Path | None = None) -> CompiledEntry:
    """A stand-in library entry whose defaults are `smp` itself."""
    return CompiledEntry(name or _slug(smp.activity_label), smp, path or Path())


def _slug(label: str) -> str:
    return norm_name(label).replace(" ", "_") or "activity"


# -- readings and actions ------------------------------------------------------------
def _steps(smp: SMP) -> list[Step]:
    steps: list[Step] = []
    for name in smp.primitive_sequence:
        if norm_name(name) in STRUCTURAL:
            continue
        prim = smp.primitive(name)
        assert prim is not None  # validation: every entry that is not structural names a primitive
        parts = tuple(p for raw in prim.body_parts for p in normalize_body_part(raw))
        reading = read_primitive(name, prim.description, smp.activity_label)
        moves = tuple(m for m in (MOVEMENTS[n] for n in reading.movements) if _limb_named(m, parts))
        steps.append(Step(name, reading, parts, movements=moves))
    for step in steps:
        step.action = _action(step)
    _alternate(steps)
    return steps


def _held_through_cycle(steps: list[Step], cycle: list[int], smp: SMP) -> list[Movement]:
    """Excursions that every primitive of a repeated cycle names, on the same limbs and in the same
    direction ("lower the dumbbell behind the head", "raise it back overhead"): the placement the
    set is performed in, held from the start, not reached and left on every repetition. They leave
    the cycle's primitives (a primitive left with no movement holds)."""
    if len(cycle) < 2:
        return []

    def placed(step: Step) -> set[tuple[str, tuple[str, ...], int]]:
        return {(m.name, _limb_sides(m, step, smp) if m.sided else (), step.reading.direction)
                for m in step.movements if m.kind == "excursion"}

    common = {name for name, _, _ in set.intersection(*(placed(steps[i]) for i in cycle))}
    for i in cycle:
        step = steps[i]
        step.movements = tuple(m for m in step.movements if m.name not in common)
        if step.action == "go" and not step.movements:
            step.action = "hold"
    return [MOVEMENTS[name] for name in sorted(common)]


def _limb_named(move: Movement, parts: tuple[str, ...]) -> bool:
    """A limb movement needs that limb among the primitive's body parts (when it lists any)."""
    if not parts or move.limb == "none" or move.kind != "excursion":
        return True
    limb = _LEG_PARTS if move.limb == "leg" else _ARM_PARTS
    return any(p.split("_", 1)[-1] in limb or p in limb for p in parts)


def _action(step: Step) -> str:
    r = step.reading
    if any(m.kind == "gait" for m in step.movements):
        return "gait"
    if r.returns:
        return "return"
    if not step.movements:
        return "hold"
    if r.there_and_back or any(m.kind == "circle" for m in step.movements):
        return "back"  # a circle ends where it began
    return "go"


def _alternate(steps: list[Step]) -> None:
    """Left and right versions of one movement (pedal strokes, knee lifts) each go out and back."""
    for i, step in enumerate(steps):
        side = step.reading.leg_side or step.reading.arm_side
        if step.action != "go" or side is None:
            continue
        names = set(step.reading.movements)
        for j, other in enumerate(steps):
            o_side = other.reading.leg_side or other.reading.arm_side
            if j != i and o_side not in (None, side) and set(other.reading.movements) == names:
                step.action = "back"
                break


def _sets_start(step: Step) -> bool:
    """The first primitive names the posture the activity starts in (lie on the back, sit upright...)."""
    if step.action == "hold" or any(m.kind == "posture" and m.posture != "standing" for m in step.movements):
        return True
    return step.reading.posture is not None and all(m.kind == "reset" for m in step.movements)


def _start_posture(smp: SMP, steps: list[Step]) -> str:
    if steps:
        first = steps[0]
        named = [m.posture for m in first.movements if m.kind == "posture"]
        if named and named[0]:
            return named[0]
        if any(m.name == "recline" for m in first.movements):
            return "sitting"  # one reclines from a seat
        if _sets_start(first) and first.reading.posture:
            return first.reading.posture
    if any(s.action == "gait" for s in steps):
        return "standing"
    contacts = " ".join(smp.object_contact.environment_contact + smp.object_contact.objects).lower()
    if any(w in contacts for w in SEAT_WORDS) and not any(
            m.kind == "posture" for s in steps for m in s.movements):
        return "sitting"
    return "standing"


def _on_bed(smp: SMP) -> bool:
    """The SMP's contacts (its own or a primitive's) name a bed, sofa or couch."""
    oc = smp.object_contact
    words = [*oc.environment_contact, *oc.objects, *oc.required_contact,
             *(c for p in smp.motion_primitives for c in p.contact)]
    return any(re.search(r"\b(bed|sofa|couch)\b", w.lower()) for w in words)


def _weights_hang(smp: SMP) -> bool:
    """The SMP's objects or required contacts name a hand weight, and no primitive rests the
    forearms or hands on the thighs, the knees or in the lap (a seated wrist curl)."""
    held = " ".join(smp.object_contact.objects + smp.object_contact.required_contact).lower()
    resting = any(_ON_THE_LAP.search(normalize_text(p.description)) for p in smp.motion_primitives)
    return any(w in held for w in WEIGHT_WORDS) and not resting


def _periodic(smp: SMP, steps: list[Step]) -> bool:
    ts = smp.temporal_structure
    count = smp.repetition_count()
    return bool(ts.is_repetitive or ts.periodicity == "cyclic" or (count is not None and count > 1)
                or any(s.action == "gait" for s in steps))


def _static(smp: SMP, steps: list[Step]) -> bool:
    """A held posture with small movements (sitting, typing): no count, no cycle, no change of support."""
    ts = smp.temporal_structure
    return ts.periodicity in ("none", UNKNOWN) and smp.repetition_count() is None and not (
        _changes_posture(steps) or _periodic(smp, steps))


def _cycle_span(steps: list[Step]) -> tuple[list[int], list[int], list[int]]:
    """(lead-in, cycle, lead-out) indices: set-up and final return peeled off the repeated cycle."""
    if any(s.action == "gait" for s in steps):
        idx = [i for i, s in enumerate(steps) if s.action == "gait"]
        return list(range(idx[0])), list(range(idx[0], idx[-1] + 1)), list(range(idx[-1] + 1, len(steps)))
    match = _matches(steps)
    lo, hi = 0, len(steps) - 1
    while hi - lo >= 1:
        if steps[lo].action == "hold" and hi - lo >= 1:
            lo += 1
        elif hi - lo >= 2 and steps[lo].action == "go" and match.get(lo) == hi:
            lo, hi = lo + 1, hi - 1
        elif steps[hi].action == "hold" and hi - lo >= 2 and lo > 0:
            hi -= 1
        else:
            break
    return list(range(lo)), list(range(lo, hi + 1)), list(range(hi + 1, len(steps)))


def _matches(steps: list[Step]) -> dict[int, int]:
    """Outward primitive -> the primitive that undoes it (a stack, as the words nest): a return, or
    one made only of the antagonists of the outward movements ("knock", then "draw the fist back")."""
    stack: list[int] = []
    out: dict[int, int] = {}
    for i, s in enumerate(steps):
        names = tuple(m.name for m in s.movements)
        if s.action == "go" and stack and undoes(tuple(m.name for m in steps[stack[-1]].movements), names):
            out[stack.pop()] = i
        elif s.action == "go":
            stack.append(i)
        elif s.action == "return" and stack:
            out[stack.pop()] = i
    return out


# -- poses ---------------------------------------------------------------------------------
def _posture_vector(posture: str, root_dz: float) -> np.ndarray:
    if posture == "plank":
        values = {k: float(v) for k, v in PLANK_POSE.items() if k != "like"}
        vec = pose_vector(values, pose_vector(BUILTIN_POSES["lying_prone"]))
    else:
        vec = pose_vector(BUILTIN_POSES.get(posture, BUILTIN_POSES["standing"]))
    vec[DOF_INDEX["root_dz"]] = root_dz
    return vec


def _limb_sides(move: Movement, step: Step, smp: SMP) -> tuple[str, ...]:
    explicit = step.reading.leg_side if move.limb == "leg" else step.reading.arm_side
    if explicit:
        return (explicit,)
    limb = _LEG_PARTS if move.limb == "leg" else _ARM_PARTS
    sides = {side_of(p) for p in step.parts if p.split("_", 1)[-1] in limb and side_of(p)}
    if not sides:
        dominant = [normalize_body_part(p) for p in smp.body_parts.dominant_moving_segments]
        sides = {side_of(p) for ps in dominant for p in ps if p.split("_", 1)[-1] in limb and side_of(p)}
    if len(sides) == 1:
        return (sides.pop(),)
    ea = smp.execution_attributes
    if not sides and ea.dominant_side in ("left", "right") and ea.symmetry == "asymmetric":
        return (ea.dominant_side,)
    return ("left", "right")


def _apply(current: np.ndarray, moves: list[Movement], step: Step, smp: SMP, direction_hint: int,
           neutral: np.ndarray | None = None, aim: np.ndarray | None = None) -> np.ndarray:
    """`current` with the movements' targets set (their first DOF last, so it wins); a relative
    root travel counts from the posture's `neutral` pose (else from `current`), so a second
    squat does not sink the pelvis further, and setting it twice does not add it twice. With `aim`,
    the shoulder angles an arm's movements leave unset come from it (`_aim_from`)."""
    out = current.copy()
    if aim is not None:
        _aim_from(out, moves, step, smp, aim)
    for primary in (False, True):
        for move in moves:
            if move.kind == "reset":
                continue
            items = list(move.pose.items())[:1] if primary else list(move.pose.items())
            for stem, value in items:
                for col, val in _targets(move, stem, value, step, smp,
                                         current if neutral is None else neutral, direction_hint):
                    out[col] = val
    return out


def _aim_from(out: np.ndarray, moves: list[Movement], step: Step, smp: SMP, neutral: np.ndarray) -> None:
    """An arm sent in a direction points there: the shoulder angles its movements do not set go back
    to `neutral`'s (after "out to the side", "move the hand straight up" raises the arm in front,
    not in front and out to the side at once)."""
    named = {stem for m in moves for stem in m.pose}
    for move in moves:
        if move.kind != "excursion" or not any(stem in move.pose for stem in SHOULDER_AIM):
            continue
        for side in _limb_sides(move, step, smp) if move.sided else ("left", "right"):
            cols = [DOF_INDEX[f"{side}_{stem}"] for stem in SHOULDER_AIM if stem not in named]
            out[cols] = neutral[cols]


def _targets(move: Movement, stem: str, value: float, step: Step, smp: SMP, origin: np.ndarray,
             hint: int) -> list[tuple[int, float]]:
    if stem in SIDE_DOFS:
        sides = _limb_sides(move, step, smp) if move.sided else ("left", "right")
        if move.name == "lunge":
            return _lunge(stem, value, sides[0])
        return [(DOF_INDEX[f"{s}_{stem}"], float(value)) for s in sides]
    col = DOF_INDEX[stem]
    if stem in ("trunk_twist", "trunk_lean", "root_yaw", "head_turn"):
        sign = step.reading.direction or hint or 1
        heading = origin[col] if stem == "root_yaw" else 0.0  # a turn turns from where the body faces
        return [(col, heading + float(value) * sign)]
    if stem in ("root_dz", "root_dy"):
        if move.kind == "jump":
            return []  # the root rises in the air (_hop) and lands where it took off
        return [(col, origin[col] + float(value))]
    return [(col, float(value))]


def _lunge(stem: str, value: float, front: str) -> list[tuple[int, float]]:
    """The front leg flexes hip and knee; the rear leg extends at the hip and bends the knee."""
    back = "right" if front == "left" else "left"
    rear = {"hip_flex": -15.0, "knee_flex": 85.0, "ankle_flex": -20.0}
    return [(DOF_INDEX[f"{front}_{stem}"], float(value)), (DOF_INDEX[f"{back}_{stem}"], rear.get(stem, 0.0))]


def _reset(current: np.ndarray, moves: list[Movement], base: np.ndarray) -> np.ndarray:
    out = current.copy()
    for move in moves:
        if move.kind == "reset":
            for stem in move.pose:
                cols = [DOF_INDEX[f"{s}_{stem}"] for s in ("left", "right")] if stem in SIDE_DOFS else [
                    DOF_INDEX[stem]]
                out[cols] = base[cols]
    return out


# -- keyframes ----------------------------------------------------------------------------------
def _keyframes(steps: list[Step], base: np.ndarray, posture: str, smp: SMP, cycle: list[int]) -> None:
    current, stack, root_dz, start_posture = base.copy(), [], 0.0, posture
    cycle_start, bed, risen = None, _on_bed(smp), False
    arms = np.array([DOF_INDEX[f"{side}_{stem}"] for side in ("left", "right") for stem in _ARM_STEMS])
    placed = arms[np.abs(base - _posture_vector(posture, 0.0))[arms] > CHANGE_DEG]
    for i, step in enumerate(steps):
        if cycle and i == cycle[0]:
            cycle_start = current.copy()
        before = current.copy()
        step.start = before
        step.movements = _seated(step.movements, posture, _reached_later(steps, i, "lying"))
        rest = base if posture == start_posture else _posture_vector(posture, root_dz)  # arms at rest here
        moves = [m for m in step.movements if m.kind not in ("gait",)]
        if posture == "plank":  # the hands are planted: bending the elbows lowers the body
            moves = [MOVEMENTS["push_up_lower"] if m.name == "elbow_flexion" else m for m in moves]
        hint = _twist_hint(current, smp)
        post = next((m for m in moves if m.kind == "posture"), None)
        if post is not None and post.posture == posture and not _tipped(current, posture):
            # already there: standing up from a squat straightens the legs; any other posture is kept
            moves = [m for m in moves if m is not post]
            if post.posture == "standing":
                moves += [MOVEMENTS["leg_straighten"], MOVEMENTS["trunk_upright"]]
            post = None
            if step.action == "hold" and moves:
                step.action = "go"
            elif not moves and step.action == "go":
                step.action = "hold"
        if step.action in ("hold", "gait"):
            step.keys = []
        elif step.action == "return":  # back where the last outward primitive started, standing up if told
            target = _reset(stack.pop() if stack else base.copy(), [m for m in moves if m.kind == "reset"], base)
            if i == len(steps) - 1:  # the last one ("lower the right arm") lowers the arms to rest
                sides = (step.reading.arm_side,) if step.reading.arm_side else ("left", "right")
                cols = [DOF_INDEX[f"{side}_{stem}"] for side in sides for stem in _ARM_STEMS]
                target[cols] = rest[cols]
            jumps = any(m.kind == "jump" for m in moves)
            step.keys = _hop(before, target) if jumps else [(1.0, target, "stop")]
            current = target
        elif post is not None:
            step.changes_posture = True
            root_dz = _posture_shift(posture, post.posture, root_dz, bed)
            upper = [m for m in moves if m.kind == "excursion" and m.limb != "leg"]  # the legs follow the posture
            if posture == "lying" and post.posture == "sitting" and _reached_later(steps, i, "sitting"):
                upper.append(MOVEMENTS["recline"])  # halfway up, on the hands: a later primitive sits
            target = _posture_vector(post.posture, root_dz)
            target[placed] = before[placed]  # arms placed from the start (crossed, on the hips) stay placed
            target[_YAW] = before[_YAW]  # the body keeps its heading (turned to sit on the bed's edge)
            risen = (posture == "lying" or risen) and post.posture != "lying"  # getting up from lying
            if risen:  # undoes the turn of lying down (the same bed side)
                hint = -hint
            target = _apply(target, upper, step, smp, hint)
            via = _via(posture, post.posture, before, target, root_dz, bed)
            if via is not None:
                via[placed] = target[placed]  # crossed arms stay crossed on the way (a sit-up)
            step.keys = ([(0.5, via, "smooth")] if via is not None else []) + [(1.0, target, "stop")]
            posture = post.posture or posture
            stack.append(before)
            current = target
        else:
            start = _reset(before, moves, base)
            if posture == "sitting" and any(m.name == "squat" for m in moves):  # the seat-off crouch
                start = _crouch_off_seat(before)
                moves = [m for m in moves if m.name != "squat"]
            target = _apply(start, [m for m in moves if m.kind in ("excursion", "swing")], step, smp, hint,
                            neutral=_posture_vector(posture, root_dz), aim=rest)
            step.keys = _shape(step, moves, before, target)
            if step.action == "go":
                stack.append(before)
                current = target
        if cycle and i == cycle[-1] and cycle_start is not None:
            _close(step, before, current, cycle_start)
            current = cycle_start


def _seated(moves: tuple[Movement, ...], posture: str, lies_later: bool) -> tuple[Movement, ...]:
    """One reclines from a seat: from any other posture "recline" lies down; seated, leaning the trunk
    back before lying down is the recline on the hands (the first half of lying down)."""
    swap = {"recline": "lie_down"} if posture != "sitting" else {"trunk_extension": "recline"} if lies_later else {}
    return tuple(MOVEMENTS[swap[m.name]] if m.name in swap else m for m in moves)


def _reached_later(steps: list[Step], i: int, posture: str) -> bool:
    """A primitive after the i-th reaches `posture` (lies down; sits again, "swinging the legs down to sit")."""
    return any(m.kind == "posture" and m.posture == posture for s in steps[i + 1:] for m in s.movements)


def _tipped(current: np.ndarray, posture: str) -> bool:
    """The body is tipped out of its posture (reclined on the hands while sitting)."""
    pitch = DOF_INDEX["root_pitch"]
    return abs(current[pitch] - _posture_vector(posture, 0.0)[pitch]) > CHANGE_DEG


def _twist_hint(current: np.ndarray, smp: SMP) -> int:
    """Sign of a turn or twist whose words give no side: back through the middle, else toward the dominant side."""
    twist = current[DOF_INDEX["trunk_twist"]]
    if abs(twist) > CHANGE_DEG:
        return -int(np.sign(twist))
    return -1 if smp.execution_attributes.dominant_side == "right" else 1


def _shape(step: Step, moves: list[Movement], before: np.ndarray, target: np.ndarray) -> list[tuple]:
    kinds = {m.kind for m in moves}
    if "circle" in kinds:
        return _circle(step, before)
    if "jump" in kinds:
        keys = _hop(before, target)
        return keys + [(1.0, before, "stop")] if step.action == "back" else keys
    if step.action == "back" or "swing" in kinds and step.action != "go":
        return [(0.5, target, "stop"), (1.0, before, "stop")]
    return [(1.0, target, "stop")]


def _hop(before: np.ndarray, target: np.ndarray) -> list[tuple[float, np.ndarray, str]]:
    crouch = 0.7 * before + 0.3 * target  # the limbs move through the whole hop, at an even pace
    for stem, extra in HOP_CROUCH.items():
        crouch[[DOF_INDEX[f"left_{stem}"], DOF_INDEX[f"right_{stem}"]]] += extra
    air = 0.4 * before + 0.6 * target
    air[DOF_INDEX["root_dy"]] += MOVEMENTS["jump"].pose["root_dy"]
    air[[DOF_INDEX["left_ankle_flex"], DOF_INDEX["right_ankle_flex"]]] -= 25.0
    return [(0.3, crouch, "stop"), (0.6, air, "smooth"), (1.0, target, "stop")] if not np.allclose(
        target, before) else [(0.3, crouch, "stop"), (0.6, air, "smooth"), (0.99, target, "stop")]


def _circle(step: Step, before: np.ndarray) -> list[tuple[float, np.ndarray, str]]:
    sides = [s for s in ("left", "right") if s in {side_of(p) for p in step.parts}] or ["right"]
    if step.reading.arm_side:
        sides = [step.reading.arm_side]
    sign = -1.0 if step.reading.counter_clockwise else 1.0
    keys = []
    for k in (1, 2, 3, 4):
        phi = k * math.pi / 2.0
        vec = before.copy()
        for s in sides:
            vec[DOF_INDEX[f"{s}_shoulder_flex"]] += sign * CIRCLE_DEG * math.sin(phi)
            vec[DOF_INDEX[f"{s}_shoulder_abd"]] += CIRCLE_DEG * (1.0 - math.cos(phi))
        keys.append((k / 4.0, vec, "stop" if k == 4 else "smooth"))
    return keys


def _pelvis_offset(posture: str | None, bed: bool) -> float | None:
    """Where the pelvis sits in a posture, along the facing direction from where it stood (m):
    on a seat behind the feet; lying on a bed, a further LIE_SHIFT_M back along it."""
    return {"standing": 0.0, "kneeling": 0.0, "sitting": SEAT_SHIFT_M,
            "lying": SEAT_SHIFT_M + (LIE_SHIFT_M if bed else 0.0)}.get(posture or "")


def _posture_shift(src: str, dst: str | None, root_dz: float, bed: bool = False) -> float:
    """Pelvis travel that keeps the feet in place: onto a seat behind them, back up over them, and
    (`bed`) back along the bed when lying down from its edge (on the floor a sit-up pivots in place)."""
    start, end = _pelvis_offset(src, bed), _pelvis_offset(dst, bed)
    return root_dz if start is None or end is None else root_dz + end - start


def _via(src: str, dst: str | None, before: np.ndarray, target: np.ndarray, root_dz: float,
         bed: bool = False) -> np.ndarray | None:
    """A pose passed through: sitting between standing and lying; the recline between a seat and lying
    in one primitive; between standing and a seat, half way with the trunk leaning over the feet (the
    pelvis never dips below the seat)."""
    if {src, dst} == {"standing", "lying"}:
        return _posture_vector("sitting", root_dz + SEAT_SHIFT_M - _pelvis_offset(dst, bed))
    if {src, dst} == {"sitting", "lying"} and not (_tipped(before, src) or _tipped(target, dst)):
        seat = before if src == "sitting" else target  # half way: reclined on the hands, half turned
        half = _apply(seat, [MOVEMENTS["recline"]], None, None, 0)
        half[_YAW] = 0.5 * (before[_YAW] + target[_YAW])
        half[_DZ] = max(half[_DZ], min(before[_DZ], target[_DZ]))  # on the floor: no lower than lying
        return half
    if src == "standing" and dst == "sitting" or src == "sitting" and dst == "standing":
        return _over_the_feet(0.5 * (before + target))
    return None


def _turn_through_recline(steps: list[Step]) -> None:
    """A recline held as a primitive of its own, just before the body turns (to lie along the bed, or
    back to its edge), is half turned, as the recline passed inside one primitive is (`_via`)."""
    for step, after in pairwise(steps):
        if not (step.keys and after.keys) or after.start is None:
            continue
        end, turned_to = step.keys[-1][1], after.keys[-1][1][_YAW]
        if not _reclined(end) or abs(turned_to - end[_YAW]) <= CHANGE_DEG:
            continue
        end[_YAW] = after.start[_YAW] = 0.5 * (end[_YAW] + turned_to)


def _flow(steps: list[Step], smp: SMP) -> None:
    """One flowing change of posture does not stop between its primitives: where one moving primitive
    follows another, the body passes through the first one's last pose (`pass`: a joint that turns
    back or holds there stops there, so the pelvis never dips below a seat it rises from)."""
    if not _one_change_of_posture(smp, steps):
        return
    for step, after in pairwise(steps):
        if step.keys and after.keys and step.keys[-1][2] == "stop":
            at, vec, _ = step.keys[-1]
            step.keys[-1] = (at, vec, "pass")


def _reclined(pose: np.ndarray) -> bool:
    """The body leans back on the hands between sitting and lying."""
    return pose[DOF_INDEX["root_pitch"]] == MOVEMENTS["recline"].pose["root_pitch"]


def _crouch_off_seat(before: np.ndarray) -> np.ndarray:
    """Seated, a squat is the seat-off crouch: the legs as seated, the trunk leaning over the feet."""
    return _over_the_feet(before.copy())


def _over_the_feet(pose: np.ndarray) -> np.ndarray:
    """`pose` with the trunk leaning at least as far forward as a squat's, the pelvis rolled no further
    back than standing (it tilts forward with the trunk; only the seat rolls it back) (in place)."""
    pose[_TRUNK] = max(pose[_TRUNK], MOVEMENTS["squat"].pose["trunk_flex"])
    pose[_PELVIS] = max(pose[_PELVIS], 0.0)  # standing's: the standing pose leaves the pelvis untilted
    return pose


def _close(step: Step, before: np.ndarray, current: np.ndarray, start: np.ndarray) -> None:
    """Make the last primitive of a cycle end where the cycle started."""
    if np.abs(current - start).max() <= CHANGE_DEG * 0.01 and (not step.keys or np.allclose(step.keys[-1][1], start)):
        return
    if step.action == "gait":
        return
    if any(m.kind == "jump" for m in step.movements):
        step.keys = _hop(before, start)  # a jump that closes the cycle jumps there (jumping jacks close in the air)
        return
    if step.action == "go" and step.keys:
        step.keys = [(0.5, step.keys[-1][1], "stop"), (1.0, start, "stop")]
    elif step.keys:
        step.keys = [*step.keys[:-1], (step.keys[-1][0], start, "stop")]
    else:
        step.keys = [(1.0, start, "stop")]


# -- timing, sides, joints ---------------------------------------------------------------------
def _durations(steps: list[Step], smp: SMP) -> None:
    static = _static(smp, steps)
    for step in steps:
        nominal = step.reading.pace * max((m.nominal_s for m in step.movements), default=RETURN_S)
        if step.action == "gait":
            step.duration_s = _gait_move([step]).nominal_s  # a step's leg swing is the gait's own
        elif step.action == "hold":
            step.duration_s = STATIC_HOLD_S if static else HOLD_S
        elif step.action == "back":
            step.duration_s = 2.0 * nominal if nominal >= 0.6 else 1.6 * nominal
        else:
            step.duration_s = nominal
        if any(m.kind == "circle" for m in step.movements):
            step.duration_s = 1.6
    shares = _shares(smp, len(steps))
    if shares is not None and not any(s.action == "gait" for s in steps):
        total = sum(s.duration_s for s in steps)
        if _one_change_of_posture(smp, steps):
            # one flowing change of posture, shared out: no change of posture slower than it would be
            # alone; the phases between (holds, leans, a crouch, a straightening) take their share
            pacing = [(s, share) for s, share in zip(steps, shares, strict=True) if s.changes_posture]
            total = min(s.duration_s / share for s, share in pacing or zip(steps, shares, strict=True))
        for step, share in zip(steps, shares, strict=True):
            step.duration_s = float(np.clip(total * share, 0.15, 60.0))
    for step in steps:
        step.duration_s = max(step.duration_s, _slowest(step))


def _slowest(step: Step) -> float:
    """Shortest duration keeping every joint's mean speed along its path between keys under
    MAX_MEAN_SPEED_M_S on the default body (a curl moves the hand 0.3 m from the elbow, an arm raised
    from the trunk carries it a metre from the hips)."""
    if step.start is None or not step.keys:
        return 0.0
    ats = np.array([0.0] + [at for at, _, _ in step.keys])
    poses = np.stack([step.start] + [vec for _, vec, _ in step.keys])
    paths = _joint_paths(poses)
    return float(max(paths / MAX_MEAN_SPEED_M_S / np.maximum(np.diff(ats), 1e-3)))


def _joint_paths(poses: np.ndarray) -> np.ndarray:
    """Longest joint path (m) on the default body between consecutive poses (DOFs interpolated linearly)."""
    n, m = len(poses) - 1, PATH_SAMPLES + 1  # key intervals, poses sampled along each
    u = np.linspace(0.0, 1.0, m)[:, None, None]
    dense = (poses[:-1][None] * (1.0 - u) + poses[1:][None] * u).transpose(1, 0, 2).reshape(n * m, N_DOFS)
    root = dense[:, _ROOT]
    pos, _ = forward_kinematics_components(_BODY.offsets, _BODY.parents, local_quats_components(dense), root)
    pos = pos.reshape(n, m, len(_BODY.parents), 3)  # interval, sample, joint, xyz
    return np.linalg.norm(np.diff(pos, axis=1), axis=3).sum(axis=1).max(axis=1)


def _shares(smp: SMP, n: int) -> list[float] | None:
    raw = [v for name, v in zip(smp.primitive_sequence, smp.raw_durations(), strict=True)
           if norm_name(name) not in STRUCTURAL]
    if len(raw) != n or any(v is None or v <= 0 for v in raw):
        return None
    total = float(sum(raw))  # type: ignore[arg-type]
    return [float(v) / total for v in raw]  # type: ignore[arg-type]


def _authored_side(steps: list[Step], base: np.ndarray) -> str:
    moved = _moved_columns(steps, base)
    left = any(DOF_NAMES[c].startswith("left_") for c in moved)
    right = any(DOF_NAMES[c].startswith("right_") for c in moved)
    if left and right:
        return "bilateral"
    if left or right:
        return "left" if left else "right"
    return "none"


def _moved_columns(steps: list[Step], base: np.ndarray, threshold: float = CHANGE_DEG) -> dict[int, float]:
    """DOF column -> largest excursion from the base over all keys, root travel in centimetres (only
    columns that move)."""
    span = np.zeros(N_DOFS)
    for step in steps:
        for _, vec, _ in step.keys:
            span = np.maximum(span, np.abs(vec - base) * _CM)
    return {c: float(span[c]) for c in range(N_DOFS) if span[c] > threshold}


_JOINT_OF = {
    "shoulder_flex": "shoulder", "shoulder_abd": "shoulder", "shoulder_horiz": "shoulder", "shoulder_rot": "shoulder",
    "collar_elev": "collar", "collar_protract": "collar", "elbow_flex": "elbow", "wrist_rot": "elbow",
    "wrist_flex": "wrist", "wrist_dev": "wrist", "hip_flex": "hip", "hip_abd": "hip", "hip_rot": "hip",
    "knee_flex": "knee", "ankle_flex": "ankle", "ankle_inv": "ankle", "toe_flex": "foot",
}  # fmt: skip
_CENTER_JOINT = {"trunk_flex": "spine3", "trunk_lean": "spine3", "trunk_twist": "spine3", "root_pitch": "pelvis",
                 "root_yaw": "pelvis", "root_roll": "pelvis", "root_dy": "pelvis", "root_dz": "pelvis",
                 "root_dx": "pelvis", "head_flex": "head", "head_turn": "head", "neck_flex": "head",
                 "head_tilt": "head", "pelvis_tilt": "pelvis"}


def _joint(dof: str) -> str:
    for side in ("left", "right"):
        if dof.startswith(side + "_"):
            return f"{side}_{_JOINT_OF[dof[len(side) + 1:]]}"
    return _CENTER_JOINT[dof]


def _principal_joints(data: dict[str, Any], base: np.ndarray, steps: list[Step]) -> list[str]:
    """The joints the compiled motion moves most (keys and waves), largest first."""
    moved = _moved_columns(steps, base)
    for dof, keys in data.get("cycle", {}).get("wave", {}).items():
        values = [v for _, v in keys]
        cols = [DOF_INDEX[f"{s}_{dof}"] for s in ("left", "right")] if dof in SIDE_DOFS else [DOF_INDEX[dof]]
        for c in cols:
            moved[c] = max(moved.get(c, 0.0), float(max(values) - min(values)) * _CM[c])
    score: dict[str, float] = {}
    for col, deg in moved.items():
        joint = _joint(DOF_NAMES[col])
        score[joint] = max(score.get(joint, 0.0), deg)
    ranked = sorted(score, key=lambda j: (-score[j], j))
    strong = [j for j in ranked if score[j] >= PRINCIPAL_MIN_DEG]
    return strong or ranked[:4] or ["pelvis"]


def _paired(joints: list[str]) -> list[str]:
    """Each sided joint followed by its mirror, in order, once each."""
    out = []
    for j in joints:
        for a, b in (("left_", "right_"), ("right_", "left_")):
            if j.startswith(a):
                out += [j, b + j[len(a):]]
    return list(dict.fromkeys(out))


def _one_change_of_posture(smp: SMP, steps: list[Step]) -> bool:
    """The sequence is a single change of posture, not repeated: one flowing movement (`_durations`,
    `_flow`)."""
    return _changes_posture(steps) and not _periodic(smp, steps)


def _changes_posture(steps: list[Step]) -> bool:
    return any(m.kind == "posture" for s in steps[1:] for m in s.movements)


def _gait_move(gait: list[Step]):
    return next(m for s in gait for m in s.movements if m.kind == "gait")


def _gait_waves(gait: list[Step]) -> dict[str, Any]:
    move = _gait_move(gait)
    return {"wave": {k: [list(p) for p in v] for k, v in move.waves.items()}, "alternate": True}


def _pose_dict(vec: np.ndarray) -> dict[str, float]:
    """Every DOF written out (so no `like` chain is needed)."""
    return {name: round(float(v), 4) for name, v in zip(DOF_NAMES, vec, strict=True)}


__all__ = ["CompiledEntry", "compile_recipe", "compile_recipe_data", "compiled_entry"]
