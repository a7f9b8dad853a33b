"""The procedural motion backend: an SMP (or a prompt) -> a 3D body motion, on CPU, no weights.

The SMP's primitives, in the SMP's order and with its relative durations,
are animated with the activity's library recipe (`recipe.py`) or, for an
activity without one (or with `compile_mode="always"`), with a recipe
compiled from the SMP itself (`compiler.py`): keyframe
poses joined by minimum-jerk-like curves, repeated cycles, periodic waves
for gait-like motion, holds with idle micro-motion. The SMP's execution
attributes are realized as follows (docs/motion.md, "Controls"):

- tempo level L (0 slow .. 2 fast): every duration x TEMPO_RATIO ** (1 - L)
  (slow 1.5x, fast 0.67x the medium duration);
- amplitude level L: DOF excursions about the neutral (base) pose x
  0.6 + 0.4 L (0.6 small, 1.0 medium, 1.4 large), then soft joint limits;
- repetition count: exactly that many cycles;
- primitive durations: each primitive's relative duration divided by the
  library default (median ratio removed) scales that primitive only;
- symmetry "asymmetric": the non-dominant side lags and moves less;
- dominant side opposite to the recipe's side: the whole motion is mirrored;
- a path with turns (recipe `turns`: stairs) turns toward the dominant side when it
  is left or right, each way with equal chance otherwise;
- global displacement: locomotion travels by its foot contacts (stride
  scaled by extent / default extent within 0.75..1.25, none when
  "stationary"); other activities travel as their keyframes say and drift
  forward by whatever the SMP's extent exceeds the library default.

The seed changes the body (height, bone proportions) and the style (per-DOF
offsets, slow variability, small tempo/amplitude/duration jitter), never the
activity; it is keyed to the activity, so interventions on one SMP with one
seed share body and style.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from rapidfuzz import fuzz, process
from scipy.ndimage import uniform_filter1d

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.dofs import (
    DOF_INDEX,
    DOF_NAMES,
    LEFT_COLUMNS,
    N_DOFS,
    RIGHT_COLUMNS,
    ROTATION_COLUMNS,
    limits_array,
    local_quats_components,
    mirror_dofs,
    soft_limit,
)
from vsmp_imu.motion.measure import lowpass
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.quat import axis_angle, forward_kinematics_components, multiply, rotate
from vsmp_imu.motion.recipe import PathTurns, Recipe, recipe_for_entry
from vsmp_imu.motion.skeleton import (
    DEFAULT_HEIGHT_M,
    SMPL22_JOINTS,
    SMPL22_PARENTS,
    smpl22_skeleton,
)
from vsmp_imu.motion.tracks import (
    PeriodicWave,
    hermite_track,
    low_frequency_noise,
    minimum_jerk,
    smoothstep_ramp,
)
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp.library import ActivityMatchError
from vsmp_imu.smp.schema import MAX_MOTION_S, SMP, STRUCTURAL_NAMES, UNKNOWN, displacement_word

BACKEND_NAME = "procedural"
ROTATION_DOF_NAMES = tuple(DOF_NAMES[c] for c in ROTATION_COLUMNS)  # the DOFs in degrees
# recipe: library recipes only; fallback: the recipe where the activity has one, else the motion
# compiled from the SMP; always: every motion compiled from its SMP (recipes ignored)
COMPILE_MODES = ("recipe", "fallback", "always")
TEMPO_RATIO = 1.5  # slow = 1.5x, fast = 1/1.5x the medium duration
AMPLITUDE_SLOPE = 0.4  # factor 0.6 / 1.0 / 1.4 at small / medium / large
PRIMITIVE_MATCH_MIN = 80.0  # rapidfuzz WRatio for an SMP primitive name to match a recipe primitive
STRUCTURAL_PRIMITIVES = STRUCTURAL_NAMES  # sequence words that name no movement
MIN_SEGMENT_S = 0.05
FADE_MIN_CYCLES = 0.15  # smallest wave fade when something precedes or follows the cycle block

# Body variation across seeds (paper: a plausible population of executions).
HEIGHT_MEAN_M, HEIGHT_SD_M, HEIGHT_RANGE_M = 1.70, 0.08, (1.50, 1.95)
PROPORTION_SPREAD = 0.03
STYLE_SD_DEG = 2.0
STYLE_SIDE_SD_DEG = 0.5  # left-right difference of the style offsets
SIDE_NOISE_FRACTION = 0.4  # own (one-side) part of the slow variability
TEMPO_JITTER, AMPLITUDE_JITTER, DURATION_JITTER, CYCLE_JITTER = 0.04, 0.04, 0.05, 0.02

# Distance of a joint centre from the body surface (m, 1.70 m body): the
# lowest joint relative to its clearance rests on the floor.
_CLEARANCE_170 = {
    "pelvis": 0.10, "left_hip": 0.08, "right_hip": 0.08, "spine1": 0.10, "left_knee": 0.05,
    "right_knee": 0.05, "spine2": 0.10, "left_ankle": 0.07, "right_ankle": 0.07, "spine3": 0.10,
    "left_foot": 0.024, "right_foot": 0.024, "neck": 0.08, "left_collar": 0.07,
    "right_collar": 0.07, "head": 0.10, "left_shoulder": 0.06, "right_shoulder": 0.06,
    "left_elbow": 0.04, "right_elbow": 0.04, "left_wrist": 0.03, "right_wrist": 0.03,
}
CLEARANCE_170 = np.array([_CLEARANCE_170[j] for j in SMPL22_JOINTS])
GROUND_SOFTNESS_M = 0.004
# Locomotion root smoothing: pelvis motion in gait is dominated by the step
# frequency (about 2 Hz); a 4 Hz low-pass removes the kinks of the stance switch.
LOCOMOTION_ROOT_CUTOFF_HZ = 4.0
TRAVEL_FLUCTUATION = 0.5
# a walking pelvis (recipe `pelvis`): the arc's half-chord per step in leg lengths (a step is
# about 0.8 leg lengths in normal walking), the share of the pendulum arc in the step's height curve
# (the rest a cosine: 0.5 gives a waist's |acc| the skew of HAPT's walking, +0.5; the pure arc +1.0),
# and the low-pass that rounds the heel-strike upturn (double support lasts about 0.1 s)
PENDULUM_CHORD = 0.4
PENDULUM_SHARE = 0.5
PELVIS_CUTOFF_HZ = 4.0
CONTACT_SOFTNESS_M = 0.01
# flight (both feet off the floor, 1.70 m body): the root keeps its speed (running)
FLIGHT_START_M, FLIGHT_RAMP_M = 0.01, 0.015


def tempo_factor(level: float) -> float:
    """Duration factor of a tempo level on the 0..2 scale (monotonic decreasing)."""
    return float(TEMPO_RATIO ** (1.0 - level))


def amplitude_factor(level: float) -> float:
    """Excursion factor of an amplitude level on the 0..2 scale (monotonic increasing)."""
    return float(1.0 + AMPLITUDE_SLOPE * (level - 1.0))


@dataclass
class Segment:
    """One performed primitive."""

    primitive: str  # the recipe primitive
    smp_name: str  # the name in the SMP
    start_s: float
    end_s: float
    repetition: int | None  # cycle index (0-based) or None outside the cycle
    phase: tuple[float, float] | None = None  # cycle phase span (cycles)


@dataclass
class Plan:
    """Timing and controls of one motion, before any curve is drawn."""

    activity: str
    recipe: Recipe
    segments: list[Segment]
    duration_s: float
    natural_duration_s: float
    block: tuple[float, float] | None  # cycle block [start, end] in seconds
    cycle_s: float
    controls: dict[str, Any] = field(default_factory=dict)
    central_primitive: str | None = None  # the library entry's principal phase
    entry: Any = None  # the library entry (or the compiled stand-in) the plan was made for


class ProceduralBackend:
    """Procedural SMP-driven motion synthesis (the embedded default backend).

    `library`: an `ActivityLibrary` (default: the built-in library); `fps`:
    output frame rate.
    """

    name = BACKEND_NAME

    def __init__(self, library: Any = None, fps: float = 30.0, compile_mode: str = "fallback") -> None:
        if compile_mode not in COMPILE_MODES:
            raise ValidationError(f"unknown compile_mode '{compile_mode}'", field="compile_mode",
                                  allowed=", ".join(COMPILE_MODES))
        self.library = library
        self.fps = fps
        self.compile_mode = compile_mode

    # -- public verb ------------------------------------------------------------
    def generate(self, smp_or_prompt: SMP | str, seed: int, duration_s: float | None = None,
                 offsets_deg: dict[str, float] | None = None, duration_scale: float = 1.0) -> Motion:
        """One motion for an SMP (or a prompt) and a seed; `offsets_deg` adds constant angles to
        DOFs (posture, e.g. {"root_pitch": 5.0}), as fitted by motion-level simulation-in-the-loop;
        `duration_scale` multiplies every primitive's duration (an event timed to real ones)."""
        smp, entry, prompt = self.resolve(smp_or_prompt)
        plan = self.plan(smp, seed, duration_s, entry=entry, duration_scale=duration_scale)
        if offsets_deg:
            unknown = sorted(set(offsets_deg) - set(ROTATION_DOF_NAMES))
            if unknown:
                raise ValidationError(f"unknown DOF(s) {', '.join(unknown)}", field="offsets_deg",
                                      allowed=", ".join(ROTATION_DOF_NAMES))
            plan.controls["offsets_deg"] = {k: round(float(v), 6) for k, v in sorted(offsets_deg.items())}
        return self._synthesize(plan, smp, seed, prompt)

    def resolve(self, smp_or_prompt: SMP | str) -> tuple[SMP, Any, str | None]:
        """(SMP, library entry, prompt text) for an SMP or a free-text prompt."""
        library = self._library()
        if isinstance(smp_or_prompt, str):
            from vsmp_imu.motion.prompt import smp_from_prompt

            smp, entry = smp_from_prompt(smp_or_prompt, library)
            return smp, entry, smp_or_prompt
        if not isinstance(smp_or_prompt, SMP):
            raise ValidationError(f"expected an SMP or a prompt string, got {type(smp_or_prompt).__name__}",
                                  field="smp")
        try:
            entry = resolve_entry(library, smp_or_prompt.activity_label)
        except ValidationError:
            if self.compile_mode == "recipe":
                raise
            entry = None  # an activity the library does not know: compiled from its own SMP
        return smp_or_prompt, entry, _verbalize(smp_or_prompt)

    def plan(self, smp: SMP, seed: int, duration_s: float | None = None, entry: Any = None,
             duration_scale: float = 1.0) -> Plan:
        """The timeline and realized controls of `smp` (no curves yet)."""
        if entry is None:
            entry = self.resolve(smp)[1]
        if duration_s is not None and not (duration_s > 0 and math.isfinite(duration_s)):
            raise ValidationError(f"duration_s must be a positive number of seconds, got {duration_s}",
                                  field="duration_s")
        if not (duration_scale > 0 and math.isfinite(duration_scale)):
            raise ValidationError(f"duration_scale must be a positive number, got {duration_scale}",
                                  field="duration_scale")
        entry, recipe = self._recipe(smp, entry)
        return _plan(entry, recipe, smp, seed, duration_s, duration_scale)

    def _recipe(self, smp: SMP, entry: Any) -> tuple[Any, Recipe]:
        """The library recipe, or one compiled from the SMP (`compile_mode`, docs/motion.md)."""
        has_recipe = entry is not None and "procedural" in getattr(entry, "extras", {})
        if self.compile_mode == "recipe" or (has_recipe and self.compile_mode == "fallback"):
            if entry is None:
                return entry, recipe_for_entry(resolve_entry(self._library(), smp.activity_label))
            recipe = recipe_for_entry(entry)
            if self.compile_mode == "recipe" or _performs(smp, recipe):
                return entry, recipe
            entry = None  # another activity's recipe (a label that only resembles it): compile the SMP
        from vsmp_imu.motion.compiler import CompiledEntry, compile_recipe, compiled_entry

        if entry is None or not _same_primitives(smp, entry.smp):
            entry = compiled_entry(smp, entry.name if entry is not None else None,
                                   getattr(entry, "path", None))
        else:
            entry = CompiledEntry(entry.name, entry.smp, entry.path, entry.central_primitive)
        return entry, compile_recipe(entry.smp)

    def _library(self) -> Any:
        if self.library is None:
            from vsmp_imu.smp.library import ActivityLibrary

            self.library = ActivityLibrary.load()
        return self.library

    # -- synthesis -------------------------------------------------------------------
    def _synthesize(self, plan: Plan, smp: SMP, seed: int, prompt: str | None) -> Motion:
        recipe = plan.recipe
        fps = float(self.fps)
        if not (fps > 0 and math.isfinite(fps)):
            raise ValidationError(f"fps must be positive, got {fps}", field="fps")
        n = max(2, int(math.floor(plan.duration_s * fps + 1e-9)) + 1)
        t = np.arange(n) / fps
        rng_style = rng_for(seed, BACKEND_NAME, plan.activity, "style")
        c = plan.controls

        dofs = _dof_curves(plan, t, lag_s=c["lag_s"])
        neutral = recipe.pose("base")
        scale = np.full(N_DOFS, c["amplitude_factor"])
        exempt = recipe.exempt_columns()
        if len(exempt):
            scale[exempt] = 1.0
        if recipe.locomotion != "none":
            for name in ("hip_flex", "knee_flex", "ankle_flex"):
                for side in ("left", "right"):
                    scale[DOF_INDEX[f"{side}_{name}"]] *= c["stride_factor"]
        dofs = neutral + scale * (dofs - neutral)
        if c["symmetry"] == "asymmetric":
            dofs[:, LEFT_COLUMNS] = neutral[LEFT_COLUMNS] + c["imbalance"] * (
                dofs[:, LEFT_COLUMNS] - neutral[LEFT_COLUMNS])

        # style: constant offsets (mostly shared by both sides), slow variability, breathing
        style = np.zeros(N_DOFS)
        style[ROTATION_COLUMNS] = rng_style.normal(0.0, STYLE_SD_DEG, size=len(ROTATION_COLUMNS))
        style[RIGHT_COLUMNS] = style[LEFT_COLUMNS] + rng_style.normal(0.0, STYLE_SIDE_SD_DEG, len(LEFT_COLUMNS))
        noise = np.zeros((n, N_DOFS))
        noise[:, ROTATION_COLUMNS] = low_frequency_noise(rng_style, t, len(ROTATION_COLUMNS), recipe.idle_deg)
        # both sides drift mostly together (a shared part plus a smaller own part)
        own = low_frequency_noise(rng_style, t, 2 * len(LEFT_COLUMNS), SIDE_NOISE_FRACTION * recipe.idle_deg)
        noise[:, RIGHT_COLUMNS] = noise[:, LEFT_COLUMNS] + own[:, len(LEFT_COLUMNS):]
        noise[:, LEFT_COLUMNS] += own[:, : len(LEFT_COLUMNS)]
        f_breath = rng_style.uniform(0.2, 0.33)
        noise[:, DOF_INDEX["trunk_flex"]] += 0.6 * np.sin(2 * np.pi * f_breath * t + rng_style.uniform(0, 6.28))
        dofs = dofs + style + noise
        for name, deg in c.get("offsets_deg", {}).items():
            dofs[:, DOF_INDEX[name]] += deg
        low, high = limits_array()
        dofs = soft_limit(dofs, low, high)
        if c["mirrored"]:
            dofs = mirror_dofs(dofs)

        skeleton, height = _body(seed, plan.activity)
        s = height / DEFAULT_HEIGHT_M
        local = local_quats_components(dofs)  # (4, J, T): the layout the kinematics work in
        root = np.zeros((n, 3))
        root[:, 0] = dofs[:, DOF_INDEX["root_dx"]] * s
        root[:, 2] = dofs[:, DOF_INDEX["root_dz"]] * s
        pos, rot = forward_kinematics_components(skeleton.offsets, skeleton.parents, local, root)
        floors = _stair_floors(plan, t) if recipe.locomotion.startswith("stairs") else None
        lift = np.zeros(n)
        if recipe.grounding == "lowest":
            heights = pos[..., 1] if floors is None else pos[..., 1] - floors[:, _FLOOR_SIDE]
            lift = _ground_offset(heights, CLEARANCE_170 * s)
        lift = lift + dofs[:, DOF_INDEX["root_dy"]] * s
        travel = np.zeros((n, 3))
        steps = None
        feet = _foot_heights(pos, lift, s, None if floors is None else floors[:, :2]) \
            if recipe.locomotion != "none" else None
        if recipe.locomotion != "none" and c["displacement_m"] != 0.0:
            travel[:, 2] = _stance_travel(pos, feet, s, fps)
        elif recipe.locomotion == "none" and c["drift_m"] > 0:
            travel[:, 2] = c["drift_m"] * minimum_jerk(t / max(t[-1], 1e-9))
        if recipe.locomotion != "none":
            steps = _step_count(plan, t, feet) if recipe.pelvis is not None else None
            if steps is None:
                travel[:, 2] = _even_travel(travel[:, 2], fps)
                lift = lowpass(lift, fps, LOCOMOTION_ROOT_CUTOFF_HZ, order=2)
            else:
                # the legs' excursion factor; a longer step than the nominal keeps its rise (more
                # would take the stance foot through the floor at heel strike)
                swing = min(1.0, c["amplitude_factor"] * c["stride_factor"])
                travel[:, 0], lift, travel[:, 2] = _pendulum_pelvis(
                    recipe.pelvis, steps, _stance_side(pos, feet), lift, travel[:, 2], s, fps, swing)
        travel[:, 1] = lift
        turned = None
        if recipe.turns is not None and steps is not None:
            heading, side = _heading(recipe.turns, steps, rng_for(seed, BACKEND_NAME, plan.activity, "turns"),
                                     c["dominant_side"])
            pos, rot = _turned(pos, rot, travel, heading)
            turned = {"side": side, "turned_deg": round(float(np.degrees(abs(heading[-1] - heading[0]))), 1)}
        else:
            pos = pos + travel[:, None, :]

        meta = {
            "backend": BACKEND_NAME,
            "seed": int(seed),
            "activity": plan.activity,
            "activity_label": smp.activity_label,
            "smp_id": smp.smp_id,
            "prompt": prompt,
            "fps": fps,
            "duration_s": (n - 1) / fps,
            "natural_duration_s": plan.natural_duration_s,
            "kind": recipe.kind,
            "principal_joints": list(recipe.principal_joints),
            "symmetry_joints": list(recipe.symmetry_joints),
            "duration_joints": list(recipe.duration_joints or recipe.principal_joints),
            "central_primitive": plan.central_primitive,
            "controls": dict(c, body_height_m=round(height, 4), **({"turns": turned} if turned else {})),
            "phases": [
                {"primitive": seg.smp_name, "recipe_primitive": seg.primitive,
                 "start_s": round(seg.start_s, 4), "end_s": round(seg.end_s, 4),
                 "repetition": seg.repetition}
                for seg in plan.segments
            ],
        }
        if getattr(plan.entry, "compiled", False):
            meta["motion_source"] = "compiled"
        return Motion(pos, rot, fps, SMPL22_JOINTS, SMPL22_PARENTS, meta)


# -- library and SMP reading ------------------------------------------------------------
def resolve_entry(library: Any, label: str) -> Any:
    """The library entry whose name, alias or SMP label is `label`; nothing fuzzy.

    A label that only resembles library activities raises `ActivityMatchError`
    (exit 2) naming the closest ones: animating a look-alike activity would
    silently train a model on another activity's signal.
    """
    try:
        return library.match(label)
    except ActivityMatchError as exc:
        names = [e.name for e in library if "procedural" in e.extras]
        raise ActivityMatchError(
            f"{exc.message}; the procedural backend animates library activities only and does not "
            "substitute a similar one", label=exc.label, candidates=exc.candidates,
            allowed=", ".join(names) + " (or a library file for this activity passed with --library)") from None


def _verbalize(smp: SMP) -> str | None:
    try:
        from vsmp_imu.smp.verbalize import verbalize
    except ImportError:
        return None
    try:
        return verbalize(smp)
    except Exception:  # noqa: BLE001 - the prompt is provenance only; synthesis does not need it
        return None


def _performs(smp: SMP, recipe: Recipe) -> bool:
    """Every primitive of the SMP matches a primitive of the recipe."""
    try:
        match_primitives(smp, recipe)
    except ValidationError:
        return False
    return True


def _same_primitives(smp: SMP, default: SMP) -> bool:
    """The SMP performs the library SMP's primitives (an intervention), not a sequence of its own."""
    from vsmp_imu.smp._text import norm_name

    names = {norm_name(p) for p in default.primitive_sequence}
    return all(norm_name(p) in names for p in smp.primitive_sequence)


def match_primitives(smp: SMP, recipe: Recipe, file: Any = None,
                     activity: str | None = None) -> list[tuple[int, str, str]]:
    """[(position, SMP name, recipe primitive)] in the SMP's order; structural names ("repeat") dropped.
    `activity`: the library activity whose recipe it is (named in errors)."""
    from vsmp_imu.smp._text import norm_name

    whose = f"'{smp.activity_label}'"
    if activity and norm_name(activity) != norm_name(smp.activity_label):
        whose += f" (library activity '{activity}')"

    choices: dict[str, str] = {}
    for name, prim in recipe.primitives.items():
        choices[norm_name(name)] = name
        for alias in prim.aliases:
            choices.setdefault(norm_name(alias), name)
    out: list[tuple[int, str, str]] = []
    for i, name in enumerate(smp.primitive_sequence):
        key = norm_name(name)
        if key in STRUCTURAL_PRIMITIVES:
            continue
        if key in choices:
            out.append((i, name, choices[key]))
            continue
        hit = process.extractOne(key, list(choices), scorer=fuzz.WRatio, score_cutoff=PRIMITIVE_MATCH_MIN)
        if hit is None:
            raise ValidationError(
                f"primitive '{name}' matches no primitive of the procedural recipe of {whose}",
                file=file, field=f"primitive_sequence[{i}]",
                allowed=", ".join(recipe.primitives))
        out.append((i, name, choices[hit[0]]))
    if not out:
        raise ValidationError("the SMP names no animatable primitive", file=file,
                              field="primitive_sequence", allowed=", ".join(recipe.primitives))
    return out


def _duration_scales(smp: SMP, default: SMP, matched: list[tuple[int, str, str]]) -> list[float]:
    """Per-position duration factor: the SMP's relative duration over the library's, median removed."""
    raw = smp.raw_durations()
    defaults: dict[str, float] = {}
    for name, value in zip(default.primitive_sequence, default.raw_durations(), strict=False):
        if value is not None and value > 0:
            defaults.setdefault(name, value)
    ratios: list[float | None] = []
    for pos, _, prim in matched:
        value, ref = raw[pos], defaults.get(prim)
        ratios.append(value / ref if value is not None and value > 0 and ref else None)
    known = [r for r in ratios if r is not None]
    if not known:
        return [1.0] * len(matched)
    common = float(np.median(known))
    return [float(np.clip(r / common, 0.2, 5.0)) if r is not None else 1.0 for r in ratios]


def _level(value: Any, words: tuple[str, str, str], default: float) -> float:
    if isinstance(value, str):
        return float(words.index(value)) if value in words else default
    return float(value)


def _keyed_extent(smp: SMP, recipe: Recipe) -> float | None:
    """How far compiled keyframes travel: the pelvis's way between postures (onto a seat behind the
    feet, along a bed). A displacement word the SMP names is realized when that way falls in it."""
    travel = recipe.keyed_travel_m()
    word = smp.execution_attributes.global_displacement
    if isinstance(word, str) and travel > 0.0 and displacement_word(travel) == word:
        return smp.displacement_extent_m()
    return travel


def _controls(entry: Any, recipe: Recipe, smp: SMP, rng: np.random.Generator) -> dict[str, Any]:
    default = entry.smp
    tempo_l = _level(smp.execution_attributes.tempo, ("slow", "medium", "fast"),
                     _level(default.execution_attributes.tempo, ("slow", "medium", "fast"), 1.0))
    amp_l = _level(smp.execution_attributes.amplitude, ("small", "medium", "large"),
                   _level(default.execution_attributes.amplitude, ("small", "medium", "large"), 1.0))
    tempo_j = 1.0 + rng.uniform(-TEMPO_JITTER, TEMPO_JITTER)
    amp_j = 1.0 + rng.uniform(-AMPLITUDE_JITTER, AMPLITUDE_JITTER)
    side = smp.execution_attributes.dominant_side
    if side == UNKNOWN:
        side = default.execution_attributes.dominant_side
    authored = recipe.side if recipe.side in ("left", "right") else "right"
    mirrored = side in ("left", "right") and side != authored
    symmetry = smp.execution_attributes.symmetry
    if symmetry == UNKNOWN:
        symmetry = default.execution_attributes.symmetry
    if symmetry == UNKNOWN:
        symmetry = "symmetric"
    extent = smp.displacement_extent_m()
    default_extent = default.displacement_extent_m()
    if getattr(entry, "compiled", False) and recipe.locomotion == "none":
        default_extent = _keyed_extent(smp, recipe)  # what the keys do not travel drifts forward
    if extent is None:
        extent = default_extent if default_extent is not None else 0.0
    stride, drift = 1.0, 0.0
    if recipe.locomotion != "none" and extent > 0 and default_extent:
        stride = float(np.clip(extent / default_extent, 0.75, 1.25))
    elif recipe.locomotion == "none":
        # the recipe's keyframes realize the library's displacement; more drifts forward
        drift = max(0.0, float(extent) - float(default_extent or 0.0))
    tf = tempo_factor(tempo_l) * tempo_j
    lag = recipe.asymmetry.lag_s if recipe.asymmetry.lag_s is not None else 0.2 * recipe.medium_cycle_s()
    return {
        "tempo_level": tempo_l,
        "tempo_factor": round(tf, 6),
        "amplitude_level": amp_l,
        "amplitude_factor": round(amplitude_factor(amp_l) * amp_j, 6),
        "dominant_side": side,
        "mirrored": bool(mirrored),
        "symmetry": symmetry,
        "lag_s": round(lag * tf, 6) if symmetry == "asymmetric" else 0.0,
        "imbalance": recipe.asymmetry.imbalance if symmetry == "asymmetric" else 1.0,
        "displacement_m": float(extent),
        "stride_factor": stride,
        "drift_m": drift,
    }


def _split(matched: list[tuple[int, str, str]], cycle: list[str]) -> tuple[list[int], list[int], list[int]]:
    """Indices (into `matched`) of the lead-in, the repeated cycle and the lead-out."""
    inside = [i for i, (_, _, p) in enumerate(matched) if p in cycle]
    if not inside:
        return [], list(range(len(matched))), []
    first, last = inside[0], inside[-1]
    return list(range(first)), list(range(first, last + 1)), list(range(last + 1, len(matched)))


def _check_motion_length(name: str, count: int, counted: bool, lead_in_s: float, cycle_s: float,
                         uses_absolute: bool) -> None:
    """Refuse, before a single frame is drawn, a motion longer than MAX_MOTION_S, naming the
    field at fault: absolute durations when one repetition is already too long or the count is
    the recipe's, else the SMP's repetition count."""
    needed = lead_in_s + count * cycle_s
    if needed <= MAX_MOTION_S:
        return
    if uses_absolute and (not counted or lead_in_s + cycle_s > MAX_MOTION_S):
        one = f", one repetition {lead_in_s + cycle_s:.0f} s" if count > 1 else ""
        raise ValidationError(
            f"the absolute durations make {count} repetition(s) of '{name}' last {needed:.0f} s at this "
            f"tempo{one}", field="primitive_durations.values",
            allowed=f"seconds (at medium tempo) whose motion lasts at most {MAX_MOTION_S:g} s")
    most = int((MAX_MOTION_S - lead_in_s) // cycle_s)
    raise ValidationError(
        f"{count} repetition(s) of '{name}' at this tempo need {needed:.0f} s of motion",
        field="temporal_structure.repetition_count",
        allowed=f"a count whose motion lasts at most {MAX_MOTION_S:g} s (here at most {most})")


def _plan(entry: Any, recipe: Recipe, smp: SMP, seed: int, duration_s: float | None,
          duration_scale: float = 1.0) -> Plan:
    rng = rng_for(seed, BACKEND_NAME, entry.name, "timing")
    controls = _controls(entry, recipe, smp, rng)
    # an error here is about the SMP's own fields: the caller names the SMP's file
    matched = match_primitives(smp, recipe, activity=entry.name)
    scales = _duration_scales(smp, entry.smp, matched)
    jitter = {p: 1.0 + rng.uniform(-DURATION_JITTER, DURATION_JITTER) for p in recipe.primitives}
    absolute = smp.primitive_durations.type == "absolute"
    raw = smp.raw_durations()
    tf = controls["tempo_factor"] * duration_scale
    if duration_scale != 1.0:
        controls["duration_scale"] = round(float(duration_scale), 6)
    base = []
    for i, (pos, _, prim) in enumerate(matched):
        seconds = raw[pos] if absolute and raw[pos] else recipe.primitives[prim].duration_s * scales[i]
        base.append(max(MIN_SEGMENT_S, seconds * jitter[prim] * tf))
    lead_in, cyc, lead_out = _split(matched, recipe.cycle_primitives())
    shares = np.array([recipe.primitives[matched[i][2]].duration_s for i in cyc])
    shares = shares / shares.sum()
    cycle_s = float(sum(base[i] for i in cyc))

    count = smp.repetition_count()
    counted = count is not None and count >= 1 and recipe.kind != "static"
    if not counted:
        count = None if (recipe.continuous or recipe.kind == "static") else (
            recipe.cycle.count if recipe.cycle is not None else 1)
    rest = recipe.rest_s * tf
    tail_rest = rest if count is not None else 0.0
    lead_in_s = sum(base[i] for i in lead_in)
    lag = controls["lag_s"]

    if count is None:  # continuous: fill the duration with cycles
        total = duration_s if duration_s is not None else recipe.default_duration_s
        n_cycles = max(1, math.ceil((total - rest - lead_in_s) / max(cycle_s, 1e-6) + 1e-9))
    else:
        n_cycles = count
        uses_absolute = absolute and any(raw[pos] for pos, _, _ in matched)
        _check_motion_length(entry.name, count, counted, lead_in_s, cycle_s, uses_absolute)
    segments: list[Segment] = []
    t = rest
    for i in lead_in:
        segments.append(Segment(matched[i][2], matched[i][1], t, t + base[i], None))
        t += base[i]
    block_start = t
    k = 0
    # a continuous activity's cycles run to its end even when the jittered cycles are short
    while k < n_cycles or (count is None and t < total - 1e-9):
        cj = 1.0 + float(np.clip(rng.normal(0.0, CYCLE_JITTER), -2.5 * CYCLE_JITTER, 2.5 * CYCLE_JITTER))
        phase = float(k)
        for j, i in enumerate(cyc):
            d = base[i] * cj
            segments.append(Segment(matched[i][2], matched[i][1], t, t + d, k, (phase, phase + shares[j])))
            t += d
            phase += shares[j]
        k += 1
    block_end = t
    if count is None:
        natural = duration_s if duration_s is not None else recipe.default_duration_s
        total = natural
    else:
        for i in lead_out:
            segments.append(Segment(matched[i][2], matched[i][1], t, t + base[i], None))
            t += base[i]
        natural = t + tail_rest + lag
        if duration_s is not None and duration_s < natural - 1e-6:
            raise ValidationError(
                f"duration_s={duration_s:g} s is too short for {count} repetition(s) of "
                f"'{entry.name}' at this tempo (the motion needs {natural:.2f} s); give a longer "
                "duration, fewer repetitions or a faster tempo", field="duration_s")
        total = duration_s if duration_s is not None else natural
    controls.update(
        repetitions=count,
        continuous=count is None,
        cycle_s=round(cycle_s, 6),
        primitive_scales={matched[i][1]: round(scales[i], 6) for i in range(len(matched))},
    )
    return Plan(entry.name, recipe, segments, float(total), float(natural),
                (block_start, block_end) if cyc else None, cycle_s, controls,
                getattr(entry, "central_primitive", None), entry)


# -- curves -----------------------------------------------------------------------------
def _keys(plan: Plan) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Key times, poses, which keys stop and which are passed (`pass`: `tracks.key_velocities`)."""
    recipe = plan.recipe
    cur = recipe.pose("start")
    times, values, stops, through = [0.0], [cur], [True], [False]

    def add(time: float, value: np.ndarray, ease: str) -> None:
        if time <= times[-1] + 1e-6:
            values[-1], stops[-1] = value, stops[-1] or ease == "stop"
            through[-1] = through[-1] or ease == "pass"
            return
        times.append(time)
        values.append(value)
        stops.append(ease == "stop")
        through.append(ease == "pass")

    poses: dict[str, np.ndarray] = {}
    for seg in plan.segments:
        prim = recipe.primitives[seg.primitive]
        if not prim.keys:
            add(seg.end_s, cur, "stop")
            continue
        for key in prim.keys:
            if isinstance(key.pose, str):
                if key.pose not in poses:
                    poses[key.pose] = recipe.pose(key.pose)
                value = poses[key.pose]
            else:
                value = recipe.pose(key.pose)
            add(seg.start_s + key.at * (seg.end_s - seg.start_s), value, key.ease)
            cur = value
    add(max(plan.duration_s, times[-1]) + 1.0, cur, "stop")
    return np.array(times), np.array(values), np.array(stops), np.array(through)


def _phase_map(plan: Plan) -> tuple[np.ndarray, np.ndarray]:
    pts_t, pts_p = [], []
    for seg in plan.segments:
        if seg.phase is None:
            continue
        if not pts_t or seg.start_s > pts_t[-1] + 1e-9:
            pts_t.append(seg.start_s)
            pts_p.append(seg.phase[0])
        pts_t.append(seg.end_s)
        pts_p.append(seg.phase[1])
    return np.array(pts_t), np.array(pts_p)


def _wave_columns(plan: Plan) -> list[tuple[int, PeriodicWave, float]]:
    cached = plan.recipe.cache.get("waves")
    if cached is not None:
        return cached
    cycle = plan.recipe.cycle
    out: list[tuple[int, PeriodicWave, float]] = []
    if cycle is None or not cycle.wave:
        plan.recipe.cache["waves"] = out
        return out
    for dof, keys in cycle.wave.items():
        wave = PeriodicWave(keys)
        if dof in DOF_INDEX:
            out.append((DOF_INDEX[dof], wave, 0.0))
        else:
            out.append((DOF_INDEX[f"left_{dof}"], wave, 0.0))
            out.append((DOF_INDEX[f"right_{dof}"], wave, 0.5 if cycle.alternate else 0.0))
    plan.recipe.cache["waves"] = out
    return out


def _curves_at(plan: Plan, t: np.ndarray, keys: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
               waves: list[tuple[int, PeriodicWave, float]], phase_map: tuple[np.ndarray, np.ndarray]
               ) -> np.ndarray:
    values = hermite_track(*keys[:3], t, through=keys[3])
    if not waves or plan.block is None or len(phase_map[0]) < 2:
        return values
    start, end = plan.block
    ramp = plan.recipe.cycle.ramp if plan.recipe.cycle is not None else 0.0
    # fade the waves in when something precedes the block, out when something follows it
    ramp_in = max(ramp, FADE_MIN_CYCLES) if start > 1e-9 else ramp
    ramp_out = max(ramp, FADE_MIN_CYCLES) if end < plan.duration_s - 1e-9 else 0.0
    env = smoothstep_ramp(t, start, end, 1.0, False, False)
    if ramp_in > 0:
        env = env * minimum_jerk((t - start) / (ramp_in * plan.cycle_s))
    if ramp_out > 0:
        env = env * minimum_jerk((end - t) / (ramp_out * plan.cycle_s))
    phase = np.interp(t, phase_map[0], phase_map[1])
    for col, wave, shift in waves:
        w = wave(phase - shift)
        values[:, col] = values[:, col] + env * (w - values[:, col])
    return values


def _dof_curves(plan: Plan, t: np.ndarray, lag_s: float) -> np.ndarray:
    keys = _keys(plan)
    waves = _wave_columns(plan)
    phase_map = _phase_map(plan)
    values = _curves_at(plan, t, keys, waves, phase_map)
    if lag_s > 0:
        lagged = _curves_at(plan, np.maximum(t - lag_s, 0.0), keys, waves, phase_map)
        values[:, LEFT_COLUMNS] = lagged[:, LEFT_COLUMNS]
    return values


# -- body, ground, travel -------------------------------------------------------------------
_BONE_GROUPS = {name: name.replace("left_", "").replace("right_", "") for name in SMPL22_JOINTS}


def _body(seed: int, activity: str) -> tuple[Any, float]:
    rng = rng_for(seed, BACKEND_NAME, activity, "body")
    height = float(np.clip(rng.normal(HEIGHT_MEAN_M, HEIGHT_SD_M), *HEIGHT_RANGE_M))
    groups = sorted(set(_BONE_GROUPS.values()))
    factor = dict(zip(groups, rng.uniform(1 - PROPORTION_SPREAD, 1 + PROPORTION_SPREAD, len(groups)),
                      strict=True))
    proportions = np.array([factor[_BONE_GROUPS[j]] for j in SMPL22_JOINTS])
    skeleton = smpl22_skeleton(height, proportions)
    return skeleton, height


def _ground_offset(heights: np.ndarray, clearance: np.ndarray) -> np.ndarray:
    """Per-frame lift so the lowest joint (relative to its clearance) touches the floor (smooth max)."""
    need = clearance[None, :] - heights
    top = need.max(axis=1, keepdims=True)
    tau = GROUND_SOFTNESS_M
    return (top + tau * np.log(np.exp((need - top) / tau).sum(axis=1, keepdims=True)))[:, 0] - \
        tau * np.log(2.0)


def _even_travel(x: np.ndarray, fps: float) -> np.ndarray:
    """Forward travel with the stance-locked speed fluctuation damped and smoothed.

    Locking the stance foot makes the pelvis speed swing by about +-40 % within
    a step; measured pelvis speed varies far less (roughly +-10-15 %), so only a
    fraction of the fluctuation about the mean speed is kept.
    """
    t = np.arange(len(x)) / fps
    trend = np.polyval(np.polyfit(t, x, 1), t) if len(x) > 2 else x
    return lowpass(trend + TRAVEL_FLUCTUATION * (x - trend), fps, LOCOMOTION_ROOT_CUTOFF_HZ, order=2)


_J = {name: i for i, name in enumerate(SMPL22_JOINTS)}


def _foot_heights(pos: np.ndarray, lift: np.ndarray, s: float,
                  feet_floor: np.ndarray | None = None) -> np.ndarray:
    """(T, 2) height of the left and the right foot over the floor under it."""
    heights = []
    for k, side in enumerate(("left", "right")):
        ankle, foot = pos[:, _J[f"{side}_ankle"]], pos[:, _J[f"{side}_foot"]]
        h = np.minimum(ankle[:, 1] - _CLEARANCE_170[f"{side}_ankle"] * s,
                       foot[:, 1] - _CLEARANCE_170[f"{side}_foot"] * s) + lift
        heights.append(h if feet_floor is None else h - feet_floor[:, k])
    return np.stack(heights, axis=1)


def _stance_travel(pos: np.ndarray, h: np.ndarray, s: float, fps: float) -> np.ndarray:
    """Forward root travel that keeps the stance foot planted (soft stance weights; h: _foot_heights)."""
    fwd = [0.5 * (pos[:, _J[f"{side}_ankle"], 2] + pos[:, _J[f"{side}_foot"], 2]) for side in ("left", "right")]
    w = np.exp(-(h - h.min(axis=1, keepdims=True)) / CONTACT_SOFTNESS_M)
    w /= w.sum(axis=1, keepdims=True)
    vel = np.gradient(np.stack(fwd, axis=1), axis=0) * fps
    root_v = _hold_in_flight(-(w * vel).sum(axis=1), h.min(axis=1) / s)
    return np.concatenate([[0.0], np.cumsum(0.5 * (root_v[1:] + root_v[:-1]))]) / fps


def _stance_side(pos: np.ndarray, feet: np.ndarray) -> np.ndarray:
    """Per frame, +1 or -1: the lateral side (sign of x about the pelvis) of the lower foot."""
    lateral = np.stack([pos[:, _J[f"{side}_ankle"], 0] - pos[:, _J["pelvis"], 0] for side in ("left", "right")],
                       axis=1)
    side = np.sign(lateral.mean(axis=0))  # where each foot is, on average
    return side[np.argmin(feet, axis=1)]


def _step_count(plan: Plan, t: np.ndarray, feet: np.ndarray) -> np.ndarray | None:
    """Steps taken by each frame, whole at each heel strike: twice the cycle phase, shifted so
    that the frames where the lower foot changes fall on whole steps (None: fewer than two)."""
    pts_t, pts_p = _phase_map(plan)
    if len(pts_t) < 2:
        return None
    steps = 2.0 * np.interp(t, pts_t, pts_p)
    switch = np.flatnonzero(np.diff(np.argmin(feet, axis=1))) + 1
    if len(switch) < 2:
        return None
    offset = np.angle(np.exp(2j * np.pi * steps[switch]).mean()) / (2 * np.pi)
    return steps - offset


def _heading(turns: PathTurns, steps: np.ndarray, rng: np.random.Generator,
             side: str | None = None) -> tuple[np.ndarray, str]:
    """Heading (rad, about the vertical; positive turns left) per frame of a path of straight
    stretches and turns, counted in steps taken, and the side of every turn (also where the
    motion ends before its first turn): `side` when it is left or right (the SMP's dominant
    side), else drawn."""
    sign = float(rng.choice([-1.0, 1.0]))  # drawn either way: the stretches' draws stay the same
    if side in ("left", "right"):
        sign = 1.0 if side == "left" else -1.0
    angle = math.radians(turns.angle_deg)
    heading = np.zeros(len(steps))
    mark = steps[0] - rng.uniform(0.0, turns.straight_steps[1] + turns.turn_steps[1])
    while mark < steps[-1]:
        mark += rng.integers(turns.straight_steps[0], turns.straight_steps[1] + 1)
        length = int(rng.integers(turns.turn_steps[0], turns.turn_steps[1] + 1))
        heading += sign * angle * minimum_jerk((steps - mark) / length)
        mark += length
    return heading, "left" if sign > 0 else "right"


def _turned(pos: np.ndarray, rot: np.ndarray, travel: np.ndarray,
            heading: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body turned about the vertical by `heading` per frame, its horizontal travel (the
    body frame's x and z) laid along the turning path, its vertical travel as it was."""
    turn = axis_angle("Y", heading)
    step = np.diff(travel, axis=0, prepend=travel[:1])
    path = rotate(turn[:1], travel[:1]) + np.cumsum(rotate(turn, step), axis=0)
    path[:, 1] = travel[:, 1]
    turned = rotate(turn[:, None, :], pos) + path[:, None, :]
    return turned, multiply(turn[:, None, :], rot)


def _step_arc(u: np.ndarray) -> np.ndarray:
    """Pelvis height over one step (u = 0 at heel strike, 1 at the next): 0 at heel strike, 1 at
    mid-stance; PENDULUM_SHARE of an inverted pendulum's arc, the rest a cosine."""
    base = math.sqrt(1.0 - PENDULUM_CHORD**2)
    pendulum = (np.sqrt(1.0 - (PENDULUM_CHORD * (2.0 * u - 1.0)) ** 2) - base) / (1.0 - base)
    return PENDULUM_SHARE * pendulum + (1.0 - PENDULUM_SHARE) * 0.5 * (1.0 - np.cos(2.0 * np.pi * u))


def _pendulum_pelvis(gait, steps: np.ndarray, stance_side: np.ndarray, lift: np.ndarray,
                     forward: np.ndarray, s: float, fps: float,
                     swing: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lateral, vertical, forward) root travel of a walking pelvis (recipe.PelvisGait).

    The height and forward position the planted feet imply are kept only as their mean over a
    gait cycle (a stair's rise, the walking speed); over it each step is an inverted-pendulum arc
    (a chord of PENDULUM_CHORD leg lengths: flat at mid-stance, a sharp upturn at heel strike),
    the speed is highest where the arc is lowest, and the pelvis sways toward the stance foot.
    The rise follows the legs' excursion factor `swing` squared (a pendulum's rise grows with the
    square of its swing angle, at most 1): shorter steps bounce the pelvis less.
    """
    arc = _step_arc(np.mod(steps, 1.0))
    mean_arc = float(np.mean(_step_arc(np.linspace(0.0, 1.0, 1001))))
    rate = np.diff(steps)
    cycle = max(3, int(round(2.0 / np.median(rate[rate > 0])))) if np.any(rate > 0) else 3  # frames
    vertical = uniform_filter1d(lift, cycle, mode="nearest") + gait.rise_m * s * swing**2 * (arc - mean_arc)
    speed = uniform_filter1d(np.gradient(forward) * fps, cycle, mode="nearest")
    speed = speed * (1.0 + gait.speed_fluctuation * (mean_arc - arc) / max(mean_arc, 1.0 - mean_arc))
    forward = forward[0] + np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]))]) / fps
    sway = np.sin(np.pi * steps)
    toward = np.sign(np.sum(sway * stance_side)) or 1.0
    lateral = gait.sway_m * s * toward * sway
    return tuple(lowpass(x, fps, PELVIS_CUTOFF_HZ, order=2) for x in (lateral, vertical, forward))


def _hold_in_flight(root_v: np.ndarray, lowest_foot_m: np.ndarray) -> np.ndarray:
    """Root speed that keeps its value while both feet are off the floor (a running flight phase).

    Contact weight 1 while the lower foot is within FLIGHT_START_M of the floor (every
    frame of a walk, so walking is unchanged), 0 from FLIGHT_START_M + FLIGHT_RAMP_M up;
    in between the speed blends from the stance foot's into the last one.
    """
    contact = np.clip(1.0 - (lowest_foot_m - FLIGHT_START_M) / FLIGHT_RAMP_M, 0.0, 1.0)
    if np.all(contact == 1.0):
        return root_v
    out = root_v.copy()
    for i in range(1, len(out)):
        out[i] = contact[i] * root_v[i] + (1.0 - contact[i]) * out[i - 1]
    return out


# The floor each joint stands on, for stairs: 0 = the left foot's step, 1 = the right foot's, 2 = the lower.
_FLOOR_SIDE = np.array([
    0 if n in ("left_knee", "left_ankle", "left_foot")
    else 1 if n in ("right_knee", "right_ankle", "right_foot") else 2
    for n in SMPL22_JOINTS
])


def _stair_floors(plan: Plan, t: np.ndarray) -> np.ndarray:
    """(T, 3) step heights under the left foot, the right foot and the lower of the two.

    The cycle starts with the left foot in mid-stance and the right foot in
    mid-swing, already over its next step (one step up or down). Each foot
    then moves two steps per cycle while it swings: the left foot in the
    recipe's `stair_swing` phase window, the right foot half a cycle later.
    """
    recipe = plan.recipe
    pts_t, pts_p = _phase_map(plan)
    out = np.zeros((len(t), 3))
    if len(pts_t) < 2:
        return out
    phase = np.interp(t, pts_t, pts_p)
    w0, w1 = recipe.stair_swing
    out[:, 1] = 1.0
    for k in range(int(np.ceil(pts_p[-1])) + 1):
        out[:, 0] += 2.0 * minimum_jerk((phase - (k + w0)) / (w1 - w0))
        out[:, 1] += 2.0 * minimum_jerk((phase - (k + 0.5 + w0)) / (w1 - w0))
    out *= recipe.stair_rise_m
    if recipe.locomotion == "stairs_down":
        out = out[-1, :2].max() - out
    out[:, 2] = out[:, :2].min(axis=1)
    return out
