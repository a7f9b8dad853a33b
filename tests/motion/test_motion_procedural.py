"""The procedural backend: determinism, provenance, durations, controls, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from motion_cases import AUTHORED

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.motion import get_backend, measure
from vsmp_imu.motion.procedural import ProceduralBackend, amplitude_factor, tempo_factor
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import SMP


def _with(smp: SMP, **changes) -> SMP:
    data = smp.model_dump(mode="json")
    for path, value in changes.items():
        node = data
        keys = path.split("__")
        for k in keys[:-1]:
            node = node[k]
        node[keys[-1]] = value
    return SMP.model_validate(data)


def _phase_durations(motion, primitive: str) -> list[float]:
    return [p["end_s"] - p["start_s"] for p in motion.meta["phases"] if p["primitive"] == primitive]


def test_same_seed_same_bytes_and_seeds_vary(backend, library):
    smp = library.get("jumping_jacks").smp
    a = backend.generate(smp, seed=7)
    b = backend.generate(smp, seed=7)
    c = backend.generate(smp, seed=8)
    assert a.to_npz_bytes() == b.to_npz_bytes()
    assert a.positions.shape != c.positions.shape or not np.allclose(a.positions, c.positions)
    assert abs(a.body_height_m() - c.body_height_m()) > 1e-4
    # a different seed is the same activity: same number of cycles
    joints = a.meta["principal_joints"]
    assert measure.count_repetitions(a, joints).count == measure.count_repetitions(c, joints).count == 8


def test_meta_carries_provenance(backend, library):
    smp = library.get("two_arm_curl").smp
    m = backend.generate(smp, seed=3)
    meta = m.meta
    assert meta["backend"] == "procedural" and meta["seed"] == 3 and meta["fps"] == 30.0
    assert meta["smp_id"] == smp.smp_id and meta["activity"] == "two_arm_curl"
    assert meta["prompt"] and "curl" in meta["prompt"].lower()
    c = meta["controls"]
    for key in ("tempo_factor", "cycle_s", "repetitions", "amplitude_factor", "body_height_m"):
        assert key in c
    assert c["repetitions"] == 4
    assert abs(c["body_height_m"] - m.body_height_m()) < 0.02
    assert [p["primitive"] for p in meta["phases"]] == ["curl_up", "lower"] * 4
    starts = [p["start_s"] for p in meta["phases"]]
    assert starts == sorted(starts)


def test_body_variation_across_seeds(backend, library):
    smp = library.get("standing").smp
    heights = [backend.generate(smp, seed=s, duration_s=1.0).body_height_m() for s in range(40)]
    assert 1.62 < np.mean(heights) < 1.78 and 0.04 < np.std(heights) < 0.12
    assert min(heights) > 1.45 and max(heights) < 2.0


def test_natural_duration_and_fill(backend, library):
    walk = library.get("walking").smp
    assert backend.generate(walk, seed=0).duration_s == pytest.approx(10.0)  # continuous default
    assert backend.generate(walk, seed=0, duration_s=3.5).duration_s == pytest.approx(3.5, abs=1 / 30)
    curl = library.get("two_arm_curl").smp
    natural = backend.generate(curl, seed=0)
    longer = backend.generate(curl, seed=0, duration_s=natural.duration_s + 4.0)
    n = natural.n_frames
    # the count is performed as before, then the final rest pose is held
    assert measure.count_repetitions(longer, longer.meta["principal_joints"]).count == 4
    assert longer.meta["phases"] == natural.meta["phases"]
    tail = longer.positions[n + 10:]
    assert np.ptp(tail[:, :, 1], axis=0).max() < 0.05  # held (idle micro-motion only)
    with pytest.raises(ValidationError, match="too short for 4 repetition"):
        backend.generate(curl, seed=0, duration_s=natural.duration_s * 0.5)


def test_a_motion_too_long_names_the_field_at_fault(backend, library):
    """600 s absolute durations with the library's 8 repetitions once blamed the count."""
    jj = library.get("jumping_jacks").smp
    absolute = _with(jj, primitive_durations={"type": "absolute", "values": [600, 600, 600]})
    with pytest.raises(ValidationError) as info:
        backend.generate(absolute, seed=0)
    assert info.value.field == "primitive_durations.values" and "one repetition 18" in info.value.message
    with pytest.raises(ValidationError) as info:
        backend.generate(_with(jj, temporal_structure__repetition_count=1000), seed=0)
    assert info.value.field == "temporal_structure.repetition_count"
    assert "(here at most 5" in info.value.allowed


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan")])
def test_bad_duration(backend, library, bad):
    with pytest.raises(ValidationError, match="duration_s"):
        backend.generate(library.get("walking").smp, seed=0, duration_s=bad)


def test_unknown_activity_lists_the_library(library):
    smp = _with(library.get("walking").smp, activity_label="underwater basket weaving")
    with pytest.raises(ValidationError) as info:
        ProceduralBackend(library, compile_mode="recipe").generate(smp, seed=0)
    text = info.value.render()
    assert "underwater basket weaving" in text and "walking_upstairs" in text and "jumping_jacks" in text


def test_unknown_activity_compiles_from_its_own_smp(backend, library):
    smp = _with(library.get("walking").smp, activity_label="underwater basket weaving")
    motion = backend.generate(smp, seed=0)
    assert motion.meta["motion_source"] == "compiled"
    assert motion.meta["activity"] == "underwater_basket_weaving"
    assert motion.meta["kind"] == "periodic"


def test_unmatched_primitive_lists_the_recipe_primitives(backend, library):
    smp = library.get("jumping_jacks").smp
    data = smp.model_dump(mode="json")
    data["primitive_sequence"] = ["stand", "somersault", "jump_close"]
    data["motion_primitives"][1]["name"] = "somersault"  # the sequence names a primitive of the SMP
    data["primitive_durations"]["values"] = [0.1, 0.45, 0.45]
    with pytest.raises(ValidationError) as info:
        ProceduralBackend(library, compile_mode="recipe").generate(SMP.model_validate(data), seed=0)
    err = info.value
    assert err.field == "primitive_sequence[1]" and "somersault" in err.message
    assert "jump_open" in err.allowed
    # by default a recipe that cannot perform the SMP gives way to the motion compiled from it
    motion = backend.generate(SMP.model_validate(data), seed=0)
    assert motion.meta["motion_source"] == "compiled"


def test_fuzzy_primitive_names_and_structural_repeat(backend, library):
    smp = library.get("jumping_jacks").smp
    data = smp.model_dump(mode="json")
    data["primitive_sequence"] = ["Stand", "jump open", "jump-close", "repeat"]
    data["primitive_durations"] = {"type": "relative", "values": [0.1, 0.45, 0.45, 0.0]}
    m = backend.generate(SMP.model_validate(data), seed=1)
    assert measure.count_repetitions(m, m.meta["principal_joints"]).count == 8


def test_unknown_attributes_fall_back_to_the_recipe(backend, library):
    smp = library.get("two_arm_curl").smp
    unknown = _with(smp, execution_attributes__tempo="unknown", execution_attributes__amplitude="unknown",
                    temporal_structure__repetition_count="unknown")
    a, b = backend.generate(smp, seed=2), backend.generate(unknown, seed=2)
    assert a.meta["controls"]["tempo_factor"] == b.meta["controls"]["tempo_factor"]
    assert b.meta["controls"]["repetitions"] == 4  # the recipe's count
    assert np.allclose(a.positions, b.positions)


def test_level_functions_are_monotonic():
    assert tempo_factor(0) == pytest.approx(1.5) and tempo_factor(2) == pytest.approx(1 / 1.5)
    assert amplitude_factor(0) == pytest.approx(0.6) and amplitude_factor(2) == pytest.approx(1.4)


@settings(max_examples=12, deadline=None)
@given(st.floats(0, 2), st.floats(0, 2))
def test_numeric_tempo_and_amplitude_levels_are_monotonic(backend, library, lo, hi):
    lo, hi = sorted((lo, hi))
    if hi - lo < 0.2:
        return
    smp = library.get("two_arm_curl").smp
    joints = library.get("two_arm_curl").extras["procedural"]["principal_joints"]
    slow = backend.generate(_with(smp, execution_attributes__tempo=lo), seed=1)
    fast = backend.generate(_with(smp, execution_attributes__tempo=hi), seed=1)
    assert measure.cycle_frequency_hz(fast, joints) > measure.cycle_frequency_hz(slow, joints)
    small = backend.generate(_with(smp, execution_attributes__amplitude=lo), seed=1)
    large = backend.generate(_with(smp, execution_attributes__amplitude=hi), seed=1)
    assert measure.range_of_motion(large, joints) > measure.range_of_motion(small, joints)


def test_one_primitive_duration_changes_that_phase_only(backend, library):
    smp = library.get("two_hand_push").smp
    data = smp.model_dump(mode="json")
    data["primitive_durations"]["values"][1] *= 1.5  # push_forward
    longer = backend.generate(SMP.model_validate(data), seed=4)
    base = backend.generate(smp, seed=4)
    for name in smp.primitive_sequence:
        ratio = _phase_durations(longer, name)[0] / _phase_durations(base, name)[0]
        assert ratio == pytest.approx(1.5 if name == "push_forward" else 1.0, rel=1e-6), name
    # the same when all values are renormalized (sum 1) after the change
    values = data["primitive_durations"]["values"]
    data["primitive_durations"]["values"] = [v / sum(values) for v in values]
    renorm = backend.generate(SMP.model_validate(data), seed=4)
    assert _phase_durations(renorm, "retract") == pytest.approx(_phase_durations(base, "retract"))


def test_dominant_side_mirrors_the_motion(backend, library):
    smp = library.get("right_hand_wave").smp
    right = backend.generate(smp, seed=5)
    left = backend.generate(_with(smp, execution_attributes__dominant_side="left"), seed=5)
    j = right.joint_names
    rw, lw = j.index("right_wrist"), j.index("left_wrist")
    lift = lambda m, i: m.positions[:, i, 1].max() - m.positions[0, i, 1]  # noqa: E731
    assert lift(right, rw) > 0.5 and lift(right, lw) < 0.15
    assert lift(left, lw) > 0.5 and lift(left, rw) < 0.15
    assert left.meta["controls"]["mirrored"] and not right.meta["controls"]["mirrored"]


def test_walking_travels_and_stationary_activities_do_not(backend, library):
    walk = backend.generate(library.get("walking").smp, seed=1)
    root = walk.positions[:, 0]
    speed = (root[-1, 2] - root[0, 2]) / walk.duration_s
    cadence = 2.0 / walk.meta["controls"]["cycle_s"]  # steps per second
    assert 0.8 < speed < 1.7 and 0.45 < speed / cadence < 0.8  # step length 0.45..0.8 m
    assert abs(root[-1, 0] - root[0, 0]) < 0.3
    fast = backend.generate(intervene(library.get("walking").smp, "tempo", "fast"), seed=1)
    assert (fast.positions[-1, 0, 2] - fast.positions[0, 0, 2]) / fast.duration_s > speed
    for name in ("jumping_jacks", "two_arm_curl", "sitting", "jogging_in_place", "forward_lunge"):
        m = backend.generate(library.get(name).smp, seed=1)
        drift = np.linalg.norm(m.positions[-1, 0, [0, 2]] - m.positions[0, 0, [0, 2]])
        assert drift < 0.1, name
    # transitions move as their keyframes say (about the depth of a chair), no extra drift
    sit = backend.generate(library.get("stand_to_sit").smp, seed=1)
    assert -0.5 < sit.positions[-1, 0, 2] - sit.positions[0, 0, 2] < -0.3


def test_treadmill_walking_and_displacement_extent(backend, library):
    smp = library.get("walking").smp
    still = backend.generate(_with(smp, execution_attributes__global_displacement="stationary"), seed=1)
    assert abs(still.positions[-1, 0, 2] - still.positions[0, 0, 2]) < 0.05
    short = backend.generate(_with(smp, execution_attributes__global_displacement=3.0), seed=1)
    long = backend.generate(_with(smp, execution_attributes__global_displacement=5.0), seed=1)
    travel = lambda m: m.positions[-1, 0, 2] - m.positions[0, 0, 2]  # noqa: E731
    assert travel(long) > travel(short)
    drift = backend.generate(_with(library.get("two_arm_curl").smp,
                                   execution_attributes__global_displacement=1.5), seed=1)
    assert drift.positions[-1, 0, 2] - drift.positions[0, 0, 2] == pytest.approx(1.5, abs=0.05)


def test_compiled_keyframes_travel_their_postures_way_and_only_the_rest_drifts(library):
    """A compiled change of posture moves the pelvis onto the seat behind the feet (or along a bed):
    that way is the SMP's "small" displacement, so nothing more drifts; an activity whose keys travel
    nowhere drifts its whole extent, and a number in metres drifts what the keys leave of it."""
    compiled = ProceduralBackend(library, compile_mode="always")
    travel = lambda m: m.positions[-1, 0, 2] - m.positions[0, 0, 2]  # noqa: E731
    sit = library.get("stand_to_sit").smp
    assert sit.execution_attributes.global_displacement == "small"
    assert -0.5 < travel(compiled.generate(sit, seed=1)) < -0.3
    assert 0.35 < travel(compiled.generate(library.get("lie_to_sit").smp, seed=1)) < 0.55
    curl = library.get("two_arm_curl").smp
    for extent in ("small", 1.5):
        moved = compiled.generate(_with(curl, execution_attributes__global_displacement=extent), seed=1)
        assert travel(moved) == pytest.approx(1.0 if extent == "small" else 1.5, abs=0.05)
    keyed = compiled.generate(sit, seed=1)
    farther = compiled.generate(_with(sit, execution_attributes__global_displacement=1.5), seed=1)
    assert travel(farther) - travel(keyed) == pytest.approx(1.5 - 0.4, abs=0.05)  # the keys' 0.4 m counted


def test_stairs_rise_and_fall(backend, library):
    up = backend.generate(library.get("walking_upstairs").smp, seed=2)
    down = backend.generate(library.get("walking_downstairs").smp, seed=2)
    cycles_up = up.duration_s / up.meta["controls"]["cycle_s"]
    rise = up.positions[-1, 0, 1] - up.positions[0, 0, 1]
    assert rise / (2 * cycles_up) == pytest.approx(0.17, abs=0.02)  # one 17 cm step per step
    assert down.positions[-1, 0, 1] < down.positions[0, 0, 1] - 1.0
    for m in (up, down):  # forward along their turning path
        assert np.linalg.norm(np.diff(m.positions[:, 0, ::2], axis=0), axis=1).sum() > 1.0


def test_lying_is_horizontal(backend, library):
    m = backend.generate(library.get("lying").smp, seed=0, duration_s=2.0)
    j = m.joint_names
    body = m.positions[:, j.index("head")] - m.positions[:, j.index("pelvis")]
    assert np.abs(body[:, 1]).max() < 0.25 * np.linalg.norm(body, axis=1).min()
    assert m.positions[:, :, 1].max() < 0.45


@pytest.mark.parametrize("name", AUTHORED)
def test_every_activity_is_plausible(backend, library, name):
    from vsmp_imu.motion.selfcheck import plausibility

    m = backend.generate(library.get(name).smp, seed=11)
    p = plausibility(m)
    assert p["finite"] == 1.0
    assert p["min_foot_y_m"] > -0.03
    assert p["max_step_fraction"] < 0.20
    assert p["bone_spread_m"] < 1e-6


def test_get_backend(library):
    assert get_backend("procedural", library=library).name == "procedural"
    assert get_backend("HY-Motion").name == "hymotion"
    with pytest.raises(ConfigError, match="unknown motion backend"):
        get_backend("mocap")


def test_fps_is_honoured(library):
    m = ProceduralBackend(library, fps=50.0).generate(library.get("two_arm_curl").smp, seed=0)
    assert m.fps == 50.0 and m.meta["fps"] == 50.0
    ref = ProceduralBackend(library, fps=30.0).generate(library.get("two_arm_curl").smp, seed=0)
    assert m.duration_s == pytest.approx(ref.duration_s, abs=0.04)


@pytest.mark.parametrize("name", AUTHORED)
def test_fast_and_large_execution_stays_plausible(backend, library, name):
    from vsmp_imu.motion.selfcheck import is_plausible

    smp = intervene(intervene(library.get(name).smp, "tempo", "fast"), "amplitude", "large")
    assert is_plausible(backend.generate(smp, seed=3))


@pytest.mark.parametrize("source", ["recipe", "compiled"])
@pytest.mark.parametrize("name", ["walking", "walking_upstairs", "walking_downstairs"])
def test_a_walking_pelvis_turns_as_much_as_normative_gait(backend, library, name, source, straight):
    """Pelvic obliquity and transverse rotation of about ±5° per stride and a tilt of about ±2° per
    step (normative gait kinematics): a waist sensor's rotation rate about each axis then has a
    within-window spread of at least 0.2 rad/s (real HAPT waists: 0.33-0.54), on a straight path;
    with the library's recipes and compiled from the SMP alone."""
    import dataclasses

    from vsmp_imu.imu import simulate_kinematics

    if source == "compiled":
        library = ActivityLibrary([dataclasses.replace(e, extras={}) for e in library])
        backend = ProceduralBackend(library)

    kin = simulate_kinematics(backend.generate(library.get(name).smp, seed=0, duration_s=8.0), "waist", 50.0)
    gyr = kin.gyr_seg[100:300]  # two 2 s windows inside the walk
    spread = np.stack([gyr[:100].std(axis=0), gyr[100:].std(axis=0)]).mean(axis=0)
    assert np.all(spread >= 0.2), spread
    assert np.all(spread <= 0.6), spread


@pytest.fixture
def straight(monkeypatch):
    """Gaits with `turns` (the stairs) keep their heading: the pelvis path alone."""
    from vsmp_imu.motion import procedural

    monkeypatch.setattr(procedural, "_heading", lambda turns, steps, rng, side=None: (np.zeros(len(steps)), "left"))


def _peak_hz(x: np.ndarray, fps: float) -> float:
    freqs = np.fft.rfftfreq(len(x), 1.0 / fps)
    power = np.abs(np.fft.rfft(x - x.mean())) ** 2
    power[freqs < 0.5] = 0.0
    return float(freqs[np.argmax(power)])


@pytest.mark.parametrize("mode", ["recipe", "always"])
@pytest.mark.parametrize("name", ["walking", "walking_upstairs", "walking_downstairs"])
def test_a_walking_pelvis_rises_once_per_step_and_sways_toward_the_stance_foot(library, name, mode, straight):
    """Inverted-pendulum gait (recipe `pelvis`): the pelvis rises and falls once per step by about
    the recipe's rise, its vertical acceleration peaks at the step rate (not twice it) and is skewed
    upward (the sharp upturn at heel strike), its forward acceleration follows the step rate, and it
    sways once per stride toward the foot on the floor; so does the motion compiled from the SMP
    (on a straight path: the stairs' landings turn the world axes away from the body's)."""
    from scipy.stats import skew

    from vsmp_imu.motion.recipe import recipe_for_entry

    entry = library.get(name)
    motion = ProceduralBackend(library, compile_mode=mode).generate(entry.smp, seed=0, duration_s=8.0)
    assert (motion.meta.get("motion_source") == "compiled") is (mode == "always")
    fps, pelvis = motion.fps, motion.positions[:, 0]
    steps = [p for p in motion.meta["phases"] if p["repetition"] is not None]
    step_hz = len(steps) / (steps[-1]["end_s"] - steps[0]["start_s"])
    inner = slice(int(fps), -int(fps))
    t = np.arange(len(pelvis)) / fps
    vertical = pelvis[:, 1] - np.polyval(np.polyfit(t, pelvis[:, 1], 1), t)
    acc = np.gradient(np.gradient(pelvis, axis=0), axis=0) * fps**2
    assert abs(_peak_hz(acc[inner, 1], fps) - step_hz) < 0.25
    assert abs(_peak_hz(acc[inner, 2], fps) - step_hz) < 0.25
    assert skew(acc[inner, 1]) > 0.3
    rise = recipe_for_entry(entry).pelvis.rise_m * motion.meta["controls"]["body_height_m"] / 1.70
    per_step = [np.ptp(vertical[int(p["start_s"] * fps):int(p["end_s"] * fps)]) for p in steps[1:-1]]
    assert 0.5 * rise < np.median(per_step) < 1.5 * rise
    lateral = pelvis[:, 0] - pelvis[:, 0].mean()
    assert abs(_peak_hz(lateral[inner], fps) - step_hz / 2) < 0.2
    feet = motion.positions[:, [10, 11]]  # left_foot, right_foot
    speed = np.linalg.norm(np.gradient(feet, axis=0), axis=-1)
    stance = feet[np.arange(len(feet)), np.argmin(speed, axis=1), 0]  # the slower (planted) foot's x
    assert np.corrcoef(lateral[inner], stance[inner] - pelvis[inner, 0])[0, 1] > 0.5


def test_running_keeps_the_pelvis_path_its_feet_imply(library):
    """A running pelvis is lowest at mid-stance: no walking arc, no sway (recipe and compiled)."""
    from vsmp_imu.motion.compiler import compile_recipe
    from vsmp_imu.motion.recipe import recipe_for_entry

    entry = library.get("running")
    assert recipe_for_entry(entry).pelvis is None and compile_recipe(entry.smp).pelvis is None
    motion = ProceduralBackend(library, compile_mode="always").generate(entry.smp, seed=0, duration_s=6.0)
    assert np.ptp(motion.positions[:, 0, 0]) < 0.01


def test_a_shorter_step_bounces_the_walking_pelvis_less_and_a_longer_one_no_more(library):
    """The arc's rise follows the square of the legs' excursion, capped at the nominal: a small
    amplitude bounces the pelvis less (the motion fit reads amplitude from a waist through it), a
    large one keeps the nominal rise (more would take the stance foot through the floor)."""
    from vsmp_imu.motion.selfcheck import is_plausible
    from vsmp_imu.smp.intervene import intervene

    entry = library.get("walking")
    backend = ProceduralBackend(library)

    def bounce(level: str) -> tuple[float, float]:
        motion = backend.generate(intervene(entry.smp, "amplitude", level), seed=0, duration_s=8.0)
        assert is_plausible(motion)
        fps, y = motion.fps, motion.positions[:, 0, 1]
        steps = [p for p in motion.meta["phases"] if p["repetition"] is not None][1:-1]
        factor = motion.meta["controls"]["amplitude_factor"]
        return float(np.median([np.ptp(y[int(p["start_s"] * fps):int(p["end_s"] * fps)]) for p in steps])), factor

    small, f_small = bounce("small")
    medium, _ = bounce("medium")
    large, f_large = bounce("large")
    assert f_small < 1.0 < f_large
    assert small < 0.75 * medium
    assert abs(large - medium) < 0.15 * medium
