"""The `procedural:` section of an activity-library file: how to animate an activity.

A recipe turns the primitives of an activity's SMP into joint-angle
trajectories (see `docs/motion.md`, "Writing a recipe"). It names poses
(anatomical DOF values, `vsmp_imu.motion.dofs`), gives every SMP primitive a
medium-tempo duration and keyframes, marks which primitives form the repeated
cycle, and may add periodic "waves" (gait-like DOF curves over the cycle
phase). Validation errors name the library file and the field, e.g.
``field 'procedural.primitives.jump_open.keys[0].pose'``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.dofs import (
    BUILTIN_POSES,
    DOF_NAMES,
    N_DOFS,
    SIDE_DOFS,
    TRANSLATION_DOFS,
    expand_pose,
    is_dof_name,
    pose_vector,
)
from vsmp_imu.motion.skeleton import SMPL22_JOINTS
from vsmp_imu.smp.schema import MAX_REPETITIONS
from vsmp_imu.validation import validate_model

PoseValue = dict[str, float | str]
PoseRef = str | PoseValue
KINDS = ("periodic", "discrete", "static")
LOCOMOTION = ("none", "forward", "stairs_up", "stairs_down")
SIDES = ("right", "left", "bilateral", "none")
RESERVED_POSES = ("base", "start")
# Bounds of the pose and wave numbers: an angle beyond a full turn only wraps around, and a
# pelvis offset (root_dx/dy/dz, metres for a 1.70 m body) beyond 10 m leaves any scene.
MAX_ANGLE_DEG = 360.0
MAX_OFFSET_M = 10.0
Phase = Annotated[float, Field(ge=0.0, lt=1.0, allow_inf_nan=False)]
_DOF_HELP = "a DOF of vsmp_imu.motion.dofs (e.g. elbow_flex, left_hip_flex, trunk_twist, root_dy)"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class KeyFrame(_Strict):
    """A pose reached at fraction `at` (0 < at <= 1) of its primitive."""

    at: Annotated[float, Field(gt=0.0, le=1.0)]
    pose: PoseRef
    # stop: arrive at rest (minimum-jerk-like); smooth: pass through with velocity; pass: as smooth,
    # but a DOF that turns back or holds there stops there (no swing past the key)
    ease: Literal["stop", "smooth", "pass"] = "stop"

    @model_validator(mode="before")
    @classmethod
    def _from_list(cls, data: Any) -> Any:
        # compact YAML form: [at, pose] or [at, pose, ease]
        if isinstance(data, list | tuple):
            if len(data) not in (2, 3):
                raise ValueError("a key is [at, pose] or [at, pose, ease]")
            out = {"at": data[0], "pose": data[1]}
            if len(data) == 3:
                out["ease"] = data[2]
            return out
        return data


class PrimitiveRecipe(_Strict):
    """One SMP primitive: its medium-tempo duration and its keyframes."""

    duration_s: Annotated[float, Field(gt=0.0, le=60.0)]
    keys: list[KeyFrame] = Field(default_factory=list)
    aliases: list[str] = Field(default_factory=list)

    @field_validator("keys")
    @classmethod
    def _increasing(cls, keys: list[KeyFrame]) -> list[KeyFrame]:
        ats = [k.at for k in keys]
        if any(b <= a for a, b in zip(ats, ats[1:], strict=False)):
            raise ValueError(f"key times must increase strictly, got {ats}")
        return keys


class CycleRecipe(_Strict):
    """The primitives repeated `repetition_count` times, and optional periodic waves."""

    primitives: list[str] = Field(min_length=1)
    # DOF -> [[phase, value], ...] over the cycle phase 0..1 (periodic, C2 spline)
    wave: dict[str, list[tuple[Phase, float]]] = Field(default_factory=dict)
    # the right side's wave runs half a cycle behind the left (gait, boxing)
    alternate: bool = False
    # cycles over which the waves fade in and out of the keyframed pose
    ramp: Annotated[float, Field(ge=0.0, le=1.0)] = 0.25
    # repetitions when the SMP gives no count and the recipe is not continuous
    count: Annotated[int, Field(ge=1, le=MAX_REPETITIONS)] = 1

    @field_validator("wave")
    @classmethod
    def _wave_keys(cls, wave: dict[str, list[tuple[float, float]]]) -> dict[str, list[tuple[float, float]]]:
        for dof, keys in wave.items():
            if not is_dof_name(dof):
                raise ValueError(f"unknown DOF '{dof}' in wave; use {_DOF_HELP}")
            phases = [p for p, _ in keys]
            if len(keys) < 2:
                raise ValueError(f"wave '{dof}' needs at least 2 [phase, value] keys")
            if phases[0] < 0 or phases[-1] >= 1 or any(b <= a for a, b in zip(phases, phases[1:], strict=False)):
                raise ValueError(f"wave '{dof}' phases must increase within [0, 1), got {phases}")
        return wave


class Asymmetry(_Strict):
    """How an `asymmetric` SMP is realized: the non-dominant side lags and moves less."""

    # lag (seconds at medium tempo); default 0.2 of the medium cycle duration
    lag_s: Annotated[float, Field(ge=0.0, le=5.0)] | None = None
    # excursion factor of the non-dominant side
    imbalance: Annotated[float, Field(gt=0.0, le=1.0)] = 0.7


class PelvisGait(_Strict):
    """A walking gait's pelvis path, set instead of the one the legs imply (docs/motion.md):
    an inverted-pendulum arc per step, highest at mid-stance; the forward speed fluctuating
    against it, fastest at heel strike; a sway toward the stance foot. Lengths for a 1.70 m body."""

    rise_m: Annotated[float, Field(ge=0.0, le=0.15)] = 0.05  # vertical excursion per step
    sway_m: Annotated[float, Field(ge=0.0, le=0.1)] = 0.02  # lateral half-excursion per stride
    speed_fluctuation: Annotated[float, Field(ge=0.0, le=0.5)] = 0.25  # +- fraction of the mean speed


class PathTurns(_Strict):
    """A gait path of straight stretches and turns, as a stairwell's flights and landings (docs/motion.md):
    `straight_steps` steps straight (drawn per stretch), then a turn of `angle_deg` spread over
    `turn_steps` steps, always to the same side (left or right, drawn per execution); an execution
    starts at a random point of that pattern."""

    straight_steps: tuple[Annotated[int, Field(ge=1, le=100)], Annotated[int, Field(ge=1, le=100)]] = (6, 12)
    turn_steps: tuple[Annotated[int, Field(ge=1, le=40)], Annotated[int, Field(ge=1, le=40)]] = (6, 12)
    angle_deg: Annotated[float, Field(gt=0.0, le=360.0)] = 180.0

    @model_validator(mode="after")
    def _ordered(self) -> PathTurns:
        for name in ("straight_steps", "turn_steps"):
            low, high = getattr(self, name)
            if low > high:
                raise ValueError(f"{name}: {low} > {high} (give the fewest steps first)")
        return self


class Recipe(_Strict):
    """The procedural recipe of one activity."""

    kind: Literal["periodic", "discrete", "static"]
    # the side the keyframes are written for ("right": a right-handed execution)
    side: Literal["right", "left", "bilateral", "none"] = "bilateral"
    principal_joints: list[str] = Field(min_length=1)
    symmetry_joints: list[str] = Field(default_factory=list)
    duration_joints: list[str] = Field(default_factory=list)
    base_pose: PoseRef = "standing"
    start_pose: PoseRef | None = None
    grounding: Literal["lowest", "none"] = "lowest"
    locomotion: Literal["none", "forward", "stairs_up", "stairs_down"] = "none"
    stair_rise_m: Annotated[float, Field(gt=0.0, le=0.3)] = 0.17
    # locomotion only: the pelvis path of a walking gait (None: the path the planted feet imply)
    pelvis: PelvisGait | None = None
    # locomotion with a pelvis path only: straight stretches and turns (None: straight ahead)
    turns: PathTurns | None = None
    # cycle-phase window in which the left foot moves to its next step (the right: +0.5)
    stair_swing: tuple[Annotated[float, Field(ge=0.0, lt=1.0)], Annotated[float, Field(gt=0.0, le=1.0)]] = (0.4, 0.7)
    continuous: bool = False
    default_duration_s: Annotated[float, Field(gt=0.0, le=600.0)] = 10.0
    rest_s: Annotated[float, Field(ge=0.0, le=10.0)] = 0.3
    amplitude_exempt: list[str] = Field(default_factory=list)
    asymmetry: Asymmetry = Field(default_factory=Asymmetry)
    idle_deg: Annotated[float, Field(ge=0.0, le=10.0)] = 0.8
    poses: dict[str, PoseValue] = Field(default_factory=dict)
    primitives: dict[str, PrimitiveRecipe] = Field(min_length=1)
    cycle: CycleRecipe | None = None
    _cache: dict[str, Any] = PrivateAttr(default_factory=dict)

    @property
    def cache(self) -> dict[str, Any]:
        """Compiled pieces (pose vectors, wave splines) kept with the recipe."""
        return self._cache

    @field_validator("principal_joints", "symmetry_joints", "duration_joints")
    @classmethod
    def _joints(cls, joints: list[str]) -> list[str]:
        bad = [j for j in joints if j not in SMPL22_JOINTS]
        if bad:
            raise ValueError(f"unknown joint(s) {', '.join(bad)}; allowed: {', '.join(SMPL22_JOINTS)}")
        return joints

    @field_validator("amplitude_exempt")
    @classmethod
    def _exempt(cls, names: list[str]) -> list[str]:
        bad = [n for n in names if not is_dof_name(n)]
        if bad:
            raise ValueError(f"unknown DOF(s) {', '.join(bad)}; use {_DOF_HELP}")
        return names

    @field_validator("poses")
    @classmethod
    def _pose_names(cls, poses: dict[str, PoseValue]) -> dict[str, PoseValue]:
        for name, pose in poses.items():
            if name in RESERVED_POSES or name in BUILTIN_POSES:
                raise ValueError(f"pose name '{name}' is reserved (built-in poses: "
                                 f"{', '.join(BUILTIN_POSES)}; 'base', 'start')")
            _check_pose_dict(pose, f"poses.{name}")
        return poses

    @model_validator(mode="after")
    def _bounded(self) -> Recipe:
        for where, dof, value in self._numbers():
            _check_number(dof, value, where)
        return self

    @model_validator(mode="after")
    def _references(self) -> Recipe:
        names = set(self.primitives)
        if self.cycle is not None:
            missing = [p for p in self.cycle.primitives if p not in names]
            if missing:
                raise ValueError(f"cycle.primitives names unknown primitive(s) {', '.join(missing)}; "
                                 f"defined: {', '.join(self.primitives)}")
        for pose, where in self._pose_refs():
            if isinstance(pose, str):
                if pose not in self.poses and pose not in BUILTIN_POSES and pose not in RESERVED_POSES:
                    raise ValueError(f"{where}: unknown pose '{pose}'; defined: "
                                     f"{', '.join([*self.poses, *RESERVED_POSES, *BUILTIN_POSES])}")
            else:
                _check_pose_dict(pose, where)
        for name in self.poses:
            _resolve(self, name, ())  # loops in `like` chains
        _resolve(self, "start", ())
        return self

    def _pose_refs(self) -> list[tuple[PoseRef, str]]:
        refs: list[tuple[PoseRef, str]] = [(self.base_pose, "base_pose")]
        if self.start_pose is not None:
            refs.append((self.start_pose, "start_pose"))
        for pname, prim in self.primitives.items():
            refs.extend((k.pose, f"primitives.{pname}.keys[{i}].pose") for i, k in enumerate(prim.keys))
        for pname, pose in self.poses.items():
            like = pose.get("like")
            if like is not None:
                refs.append((like, f"poses.{pname}.like"))
        return refs

    def _numbers(self) -> Iterator[tuple[str, str, float]]:
        """(field, DOF, value) of every pose and wave number (text values are `_references`' to report)."""
        poses = [(pose, f"poses.{name}") for name, pose in self.poses.items()]
        poses += [(pose, where) for pose, where in self._pose_refs() if isinstance(pose, dict)]
        for pose, where in poses:
            yield from ((f"{where}.{dof}", dof, v) for dof, v in pose.items()
                        if dof != "like" and not isinstance(v, str))
        for dof, keys in (self.cycle.wave if self.cycle is not None else {}).items():
            yield from ((f"cycle.wave.{dof}[{i}][1]", dof, v) for i, (_, v) in enumerate(keys))

    # -- compiled views -----------------------------------------------------------
    def pose(self, ref: PoseRef) -> np.ndarray:
        """The (N_DOFS,) vector of a pose name or inline pose (read-only, cached by name)."""
        if isinstance(ref, str):
            poses = self._cache.setdefault("poses", {})
            if ref not in poses:
                vec = _resolve(self, ref, ())
                vec.setflags(write=False)
                poses[ref] = vec
            return poses[ref]
        return _resolve(self, ref, ())

    def keyed_travel_m(self) -> float:
        """Farthest horizontal root travel of a key pose from the start pose (m, 1.70 m body)."""
        from vsmp_imu.motion.dofs import DOF_INDEX

        cols = [DOF_INDEX["root_dx"], DOF_INDEX["root_dz"]]
        start = self.pose(self.start_pose if self.start_pose is not None else self.base_pose)[cols]
        keys = [self.pose(k.pose)[cols] for p in self.primitives.values() for k in p.keys]
        return max((float(np.hypot(*(vec - start))) for vec in keys), default=0.0)

    def cycle_primitives(self) -> list[str]:
        return list(self.cycle.primitives) if self.cycle is not None else list(self.primitives)

    def medium_cycle_s(self) -> float:
        return float(sum(self.primitives[p].duration_s for p in self.cycle_primitives()))

    def exempt_columns(self) -> np.ndarray:
        from vsmp_imu.motion.dofs import dof_columns

        cols = [c for n in self.amplitude_exempt for c in dof_columns(n)]
        return np.array(sorted(set(cols)), dtype=int)


def _check_pose_dict(pose: PoseValue, where: str) -> None:
    for key, value in pose.items():
        if key == "like":
            if not isinstance(value, str):
                raise ValueError(f"{where}.like must name a pose")
            continue
        if not is_dof_name(key):
            raise ValueError(f"{where}: unknown DOF '{key}'; use {_DOF_HELP}")
        if isinstance(value, str):
            raise ValueError(f"{where}.{key} must be a number (degrees, or metres for root_dx/dy/dz)")


def _check_number(dof: str, value: Any, where: str) -> None:
    """Refuse a pose or wave value that is not finite or lies beyond its DOF's bound.

    Raised as a project error, which pydantic passes through, to name the value's own field."""
    bound, unit = (MAX_OFFSET_M, "m") if dof in TRANSLATION_DOFS else (MAX_ANGLE_DEG, "degrees")
    if not (math.isfinite(value) and abs(value) <= bound):
        raise ValidationError(f"{dof} = {value!r} is out of range", field=where,
                              allowed=f"a finite number within ±{bound:g} {unit}")


def _resolve(recipe: Recipe, ref: PoseRef, chain: tuple[str, ...]) -> np.ndarray:
    """A pose vector; `chain` holds the pose names being resolved (to catch loops)."""
    if isinstance(ref, dict):
        return _resolve_dict(recipe, ref, chain, default_like="base")
    if ref in chain:
        raise ValueError(f"pose '{ref}' refers to itself through 'like': {' -> '.join((*chain, ref))}")
    if ref == "base":
        base = recipe.base_pose
        if isinstance(base, dict):
            return _resolve_dict(recipe, base, (*chain, "base"), default_like="standing")
        return _resolve(recipe, base, (*chain, "base"))
    if ref == "start":
        start = recipe.start_pose if recipe.start_pose is not None else "base"
        if isinstance(start, dict):
            return _resolve_dict(recipe, start, (*chain, "start"), default_like="base")
        return _resolve(recipe, start, (*chain, "start"))
    if ref in BUILTIN_POSES:
        return pose_vector(BUILTIN_POSES[ref])
    return _resolve_dict(recipe, recipe.poses[ref], (*chain, ref), default_like="base")


def _resolve_dict(recipe: Recipe, pose: PoseValue, chain: tuple[str, ...], default_like: str) -> np.ndarray:
    like = str(pose.get("like", default_like))
    base = _resolve(recipe, like, chain)
    values = {k: float(v) for k, v in pose.items() if k != "like"}
    return pose_vector(expand_pose(values), base)


def parse_recipe(data: Any, file: str | Path | None = None) -> Recipe:
    """Validate a `procedural:` mapping; errors name the file and `procedural.<field>`."""
    if not isinstance(data, dict):
        raise ValidationError("the procedural section must be a mapping", file=file, field="procedural")
    try:
        return validate_model(Recipe, data, file)
    except ValidationError as exc:
        field = f"procedural.{exc.field}" if exc.field else "procedural"
        raise ValidationError(exc.message, file=file, field=field, allowed=exc.allowed) from None


@functools.lru_cache(maxsize=256)
def _cached_recipe(path: str, mtime_ns: int, text: str) -> Recipe:
    import json

    return parse_recipe(json.loads(text), path)


def recipe_for_entry(entry: Any) -> Recipe:
    """The recipe of a library entry (`entry.extras["procedural"]`), validated and cached."""
    import json

    data = entry.extras.get("procedural") if hasattr(entry, "extras") else None
    path = str(getattr(entry, "path", ""))
    if data is None:
        raise ValidationError(
            f"activity '{entry.name}' has no procedural recipe, so the procedural backend cannot "
            "animate it; add a `procedural:` section (docs/motion.md) or use --backend hymotion",
            file=path or None, field="procedural")
    try:
        mtime = Path(path).stat().st_mtime_ns if path else 0
    except OSError:
        mtime = 0
    return _cached_recipe(path, mtime, json.dumps(data, default=str))


def dof_help() -> str:
    """All DOF names, for error messages and docs."""
    return ", ".join(DOF_NAMES) + "; side-less stems set both sides: " + ", ".join(SIDE_DOFS)


__all__ = [
    "Asymmetry", "CycleRecipe", "KeyFrame", "N_DOFS", "PrimitiveRecipe", "Recipe",
    "dof_help", "parse_recipe", "recipe_for_entry",
]
