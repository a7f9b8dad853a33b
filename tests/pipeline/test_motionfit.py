"""Motion-level simulation-in-the-loop (`pipeline.motionfit`): the per-class CEM over the motion's
free parameters moves a mis-set parameter toward the truth, keeps a distribution, falls back
where it cannot fit, and reaches the samples and the summary."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding.align import Convention, ConventionAlignment
from vsmp_imu.grounding.stats import TargetStatistics
from vsmp_imu.imu import VirtualSensor, sensor_readings, simulate_kinematics
from vsmp_imu.pipeline.fold import _summary_lists
from vsmp_imu.pipeline.motionfit import (
    MIN_FIT_WINDOWS,
    PARAMS,
    MotionFitJob,
    bounds,
    draw,
    fit_class_motion,
    fit_text,
    realize,
)
from vsmp_imu.pipeline.sample import LocationTask, backend_for
from vsmp_imu.smp.library import ActivityLibrary

FS = 50.0
LOCATION = "waist"
CONVENTION = Convention(axes=("up", "forward", "left"), gravity_included=True)


@pytest.fixture(scope="module")
def walking():
    smp = ActivityLibrary.load().match("walking").smp
    d = smp.model_dump(mode="json")
    d["execution_attributes"]["tempo"] = 1.0  # the SMP says medium tempo
    d["execution_attributes"]["amplitude"] = 1.0
    d["constraints"]["variant_fields"] = sorted({*d["constraints"]["variant_fields"], "tempo", "amplitude"})
    return type(smp).model_validate(d)


def real_windows(smp, phi: dict[str, float], seed: int) -> np.ndarray:
    """'Real' windows of a motion performed with phi: simulated, aligned, cut as the dataset's are."""
    fitted, offsets = realize(smp, phi)
    motion = backend_for("procedural", ()).generate(fitted, seed, 30.0, offsets_deg=offsets)
    sensor = VirtualSensor.at(LOCATION)
    base = sensor.mounting_matrix()
    kin = simulate_kinematics(motion, sensor, FS)
    readings = sensor_readings(kin, base, None, None, 1.0, 1.0, True, None)[0]
    aligned = ConventionAlignment(CONVENTION).transform(readings, kin.grav_seg @ base.T)
    length, hop = int(2 * FS), int(FS)
    return np.stack([aligned[s: s + length] for s in range(0, len(aligned) - length + 1, hop)])


def job_for(smp, windows: np.ndarray, label: str = "walk") -> MotionFitJob:
    """The job the fold builds: D_stat statistics of the class's windows, their mean acceleration."""
    stats = TargetStatistics(FS).fit(windows, np.zeros(len(windows), int))
    target = _summary_lists(stats.for_class(0)) if 0 in stats.per_class_ else None
    loc = LocationTask(LOCATION, CONVENTION.as_dict(), True, target, tuple(Rotation.identity().as_quat()))
    mean = tuple(float(v) for v in windows[..., :3].reshape(-1, 3).mean(0))
    return MotionFitJob(label, smp.canonical_json(), "procedural", (), FS, (loc,), (mean,), len(windows), 7)


@pytest.mark.parametrize("name,truth,share", [("tempo", 1.9, 0.5), ("amplitude", 0.2, 0.9)])
def test_a_mis_set_parameter_moves_toward_the_truth(walking, name, truth, share):
    """The 'real' performer differs in body and style from the fitted motion's; tempo is found more
    than half way, amplitude (traded against posture in the same statistics) at least a tenth."""
    phi = dict(zip(PARAMS, bounds(walking)[0], strict=True)) | {name: truth}
    windows = real_windows(walking, phi, seed=101)
    assert len(windows) >= MIN_FIT_WINDOWS
    fit = fit_class_motion(job_for(walking, windows))
    assert fit["fitted"] and fit["loss_best"] < fit["loss_nominal"]
    k = PARAMS.index(name)
    start = fit["nominal"][k]
    assert start == 1.0
    assert abs(fit["mean"][k] - truth) < share * abs(start - truth), fit
    assert fit["low"][k] <= fit["mean"][k] <= fit["high"][k]


def test_the_fit_is_a_distribution_the_samples_draw_from(walking):
    windows = real_windows(walking, {"tempo": 1.6}, seed=5)
    fit = fit_class_motion(job_for(walking, windows))
    assert fit == fit_class_motion(job_for(walking, windows))  # same job, same bytes
    values = [v for k in ("mean", "std", "best") for v in fit[k]]
    assert all(round(v, 6) == v for v in values) and any(round(v, 5) != v for v in values)  # 6 decimals
    draws = np.array([[draw(fit, seed)[p] for p in PARAMS] for seed in range(40)])
    assert (draws >= np.array(fit["low"]) - 1e-9).all() and (draws <= np.array(fit["high"]) + 1e-9).all()
    assert draws[:, PARAMS.index("tempo")].std() > 0.05  # the samples still vary
    assert draw(fit, 3) == draw(fit, 3)


def test_invariant_and_fixed_fields_never_change(walking):
    d = walking.model_dump(mode="json")
    d["constraints"]["variant_fields"] = []  # tempo and amplitude are not free
    fixed = type(walking).model_validate(d)
    nominal, low, high = bounds(fixed)
    assert (low[:2] == high[:2]).all() and (nominal[:2] == low[:2]).all()
    changed, offsets = realize(fixed, {"tempo": 1.0, "amplitude": 1.0, "root_pitch_deg": 4.0, "root_roll_deg": 0.0})
    assert offsets == {"root_pitch": 4.0, "root_roll": 0.0}
    moved, _ = realize(walking, {"tempo": 1.7})
    before, after = walking.model_dump(), moved.model_dump()
    assert after["execution_attributes"]["tempo"] == 1.7
    for field in ("activity_label", "primitive_sequence", "motion_primitives", "body_parts", "object_contact",
                  "constraints"):
        assert after[field] == before[field]


def test_a_class_with_too_few_windows_keeps_the_smp_defaults(walking):
    windows = real_windows(walking, {}, seed=2)[: MIN_FIT_WINDOWS - 1]
    fit = fit_class_motion(job_for(walking, windows))
    assert fit == {"fitted": False, "reason": f"{MIN_FIT_WINDOWS - 1} D_stat window(s), fewer than "
                   f"{MIN_FIT_WINDOWS}", "d_stat_windows": MIN_FIT_WINDOWS - 1}
    assert fit_text(fit) == ""  # its samples get no motion parameters
    job = job_for(walking, real_windows(walking, {}, seed=2))
    not_smp = MotionFitJob(**{**job.__dict__, "smp_json": ""})
    assert "not an SMP" in fit_class_motion(not_smp)["reason"]


def test_the_fit_reaches_samples_and_summary(tiny_fold):
    """With `motion_fit` on, the fold fits each class, records it in the summary and every sample's
    motion controls hold its own draw; off, nothing changes."""
    on, off = tiny_fold(motion_fit=True), tiny_fold(motion_fit=False)
    assert "motion_fit" not in off.summary
    fits = on.summary["motion_fit"]
    assert set(fits) == {"walk"}
    fit = fits["walk"]
    assert fit["fitted"], fit
    draws = set()
    for sample in on.samples:
        controls = sample.provenance.motion.controls
        assert controls["motion_fit"] == draw(fit, sample.provenance.seed)
        draws.add(json.dumps(controls["motion_fit"], sort_keys=True))
        assert controls["offsets_deg"] == {"root_pitch": controls["motion_fit"]["root_pitch_deg"],
                                           "root_roll": controls["motion_fit"]["root_roll_deg"]}
    assert len(draws) > 1
    for sample in off.samples:
        assert "motion_fit" not in sample.provenance.motion.controls


@pytest.fixture
def tiny_fold(walking):
    """One fold of the generator on 'real' walking windows (one class, one location)."""
    from vsmp_imu.executor import LocalExecutor
    from vsmp_imu.har.dataset import DatasetInfo, SensorLocation, imu_channel_names
    from vsmp_imu.har.windows import Windows
    from vsmp_imu.pipeline.fold import FoldGenerator
    from vsmp_imu.pipeline.spec import GenerationSpec

    windows = np.concatenate([real_windows(walking, {"tempo": 1.5}, seed=s) for s in (11, 12)])
    names = imu_channel_names(None)
    info = DatasetInfo(name="walkers", fs_hz=FS, label_names=("walk",), channel_names=names,
                       locations=(SensorLocation(LOCATION, names, CONVENTION.axes, True, "m/s^2", "rad/s",
                                                 "documented"),))
    subjects = np.repeat(["1", "2"], len(windows) // 2 + 1)[: len(windows)]
    train = Windows(windows, np.zeros(len(windows), int), subjects, info.label_names, names, FS)

    def run(**switches):
        spec = GenerationSpec(k=2, quality_filter=False, **switches)
        generator = FoldGenerator(spec, LocalExecutor(1, show_progress=False))
        return generator.generate(info, train, {"walk": [("test", walking)]}, np.array([20]), 0, "f1")

    return run


def _fit(mean, std, low, high) -> dict:
    return {"fitted": True, "params": list(PARAMS), "mean": mean, "std": std, "low": low, "high": high}


def test_a_draw_is_the_mean_plus_the_spread_times_the_samples_own_normals():
    """Away from the bounds, phi = mean + max(std, DRAW_MIN_STD) * z, z the sample's 'motion-fit' normals."""
    from vsmp_imu.pipeline.motionfit import DRAW_MIN_STD
    from vsmp_imu.seeding import rng_for

    mean, std = [1.0, 1.0, 0.0, 0.0], [0.4, 0.01, 3.0, 0.5]
    fit = _fit(mean, std, [-1e3] * 4, [1e3] * 4)
    for seed in (0, 7, 123):
        z = rng_for(seed, "motion-fit").standard_normal(4)
        spread = np.maximum(std, DRAW_MIN_STD)
        assert spread[1] == DRAW_MIN_STD[1] and spread[0] == 0.4  # the floor lifts only the narrow spread
        expected = np.round(np.array(mean) + spread * z, 4)
        assert list(draw(fit, seed).values()) == pytest.approx(expected, abs=1e-12)
        assert list(draw(fit, seed)) == list(PARAMS)


def test_a_draw_stays_within_both_bounds_and_a_fixed_parameter_never_moves():
    """A mean on the lower bound puts about half the draws below it before clipping: every one is
    clipped to the bound; a parameter with low == high (not a variant field) is the bound itself."""
    fit = _fit([0.0, 1.0, 15.0, -15.0], [0.5, 0.0, 5.0, 5.0], [0.0, 1.0, -15.0, -15.0], [2.0, 1.0, 15.0, 15.0])
    draws = np.array([list(draw(fit, seed).values()) for seed in range(60)])
    assert draws[:, 0].min() == 0.0 and (draws[:, 0] == 0.0).sum() > 10  # clipped from below, not dropped
    assert draws[:, 2].max() == 15.0 and (draws[:, 2] == 15.0).sum() > 10  # clipped from above
    assert draws[:, 3].min() == -15.0 and (draws[:, 3] == -15.0).sum() > 10
    assert (draws[:, 1] == 1.0).all()
    assert draws[:, 0].max() > 0.1  # the free ones still vary


def test_the_fit_text_is_canonical_json():
    """Key order of the fit does not change the text the sample task carries (same job, same bytes)."""
    fit = {"mean": [1.0], "fitted": True, "params": ["tempo"]}
    assert fit_text(fit) == '{"fitted": true, "mean": [1.0], "params": ["tempo"]}'
    assert fit_text(dict(reversed(fit.items()))) == fit_text(fit)
    assert fit_text({"fitted": False, "reason": "x"}) == "" and fit_text(None) == ""


def test_the_motion_loss_is_the_sensor_level_l_sim_plus_the_gravity_angle(walking):
    """One candidate's loss: StreamObjective's L_sim of the class's motion at eta = 0 against D_stat,
    plus LAMBDA_GRAVITY x the angle between the simulated and the real mean accelerometer direction."""
    from vsmp_imu.grounding.calibrate import ETA_NOMINAL, StreamObjective
    from vsmp_imu.pipeline.motionfit import LAMBDA_GRAVITY, _Objective
    from vsmp_imu.seeding import rng_for

    job = job_for(walking, real_windows(walking, {"tempo": 1.4}, seed=3))
    plain = MotionFitJob(**{**job.__dict__, "mean_acc": (None,)})
    objective = _Objective(plain, walking)
    assert objective.seed == int(rng_for(job.seed, "motion-fit", "walk").integers(2**31))
    assert _Objective(MotionFitJob(**{**job.__dict__, "label": "run"}), walking).seed != objective.seed
    phi = dict(zip(PARAMS, bounds(walking)[0], strict=True)) | {"root_pitch_deg": 4.0}
    smp, offsets = realize(walking, phi)
    sensor = VirtualSensor.at(LOCATION)
    kin = simulate_kinematics(objective.backend.generate(smp, objective.seed, offsets_deg=offsets), sensor, FS)
    stream = StreamObjective(kin, job.locations[0].stat_summary(), CONVENTION, sensor.mounting_matrix())
    grav = np.array([True])
    l_sim = float(stream(ETA_NOMINAL[None], grav)[0])
    assert l_sim > 0.01
    assert objective.one(phi) == pytest.approx(l_sim, rel=1e-9)
    twice = MotionFitJob(**{**job.__dict__, "locations": job.locations * 2, "mean_acc": (None, None)})
    assert _Objective(twice, walking).one(phi) == pytest.approx(2 * l_sim, rel=1e-9)  # locations add up
    tilt = Rotation.from_euler("x", 30, degrees=True)  # a nominal mounting away from the placement's own
    loc = job.locations[0]
    tilted = LocationTask(LOCATION, CONVENTION.as_dict(), True, loc.target, tuple(tilt.as_quat()))
    on_tilt = MotionFitJob(**{**job.__dict__, "locations": (tilted,), "mean_acc": (None,)})
    expected = StreamObjective(kin, loc.stat_summary(), CONVENTION, tilt.as_matrix() @ sensor.mounting_matrix())
    l_tilt = float(expected(ETA_NOMINAL[None], grav)[0])
    assert l_tilt != pytest.approx(l_sim, rel=1e-3)
    assert _Objective(on_tilt, walking).one(phi) == pytest.approx(l_tilt, rel=1e-9)
    sim_mean = stream.mean_acc(ETA_NOMINAL[None], grav)[0]
    side = np.cross(sim_mean, [0.0, 0.0, 1.0])
    for real, angle in ((2.0 * sim_mean, 0.0), (-sim_mean, np.pi), (side, np.pi / 2)):
        with_gravity = MotionFitJob(**{**job.__dict__, "mean_acc": (tuple(real),)})
        expected = l_sim + LAMBDA_GRAVITY * angle
        assert _Objective(with_gravity, walking).one(phi) == pytest.approx(expected, abs=1e-5)


def test_the_angle_between_mean_accelerations_is_exact_at_both_ends():
    """0 for the same direction, pi for the opposite one, pi/2 across, never NaN: rounding puts the
    cosine of a vector with itself just past +-1 for about one vector in five."""
    from vsmp_imu.pipeline.motionfit import _angle

    rng = np.random.default_rng(0)
    for scale in (9.81, 300.0):
        for a in rng.normal(0.0, scale, (20, 3)):
            assert _angle(a, a) == pytest.approx(0.0, abs=1e-6) and _angle(a, 2.0 * a) == pytest.approx(0.0, abs=1e-6)
            assert _angle(a, -a) == pytest.approx(np.pi, abs=1e-6)
            assert _angle(a, np.cross(a, [1.0, 2.0, 3.0])) == pytest.approx(np.pi / 2)
    assert _angle(np.array([0.0, 0.0, 9.81]), np.array([0.0, 9.81, 9.81])) == pytest.approx(np.pi / 4)


def _with(smp, **attributes):
    d = smp.model_dump(mode="json")
    d["execution_attributes"].update(attributes)
    return type(smp).model_validate(d)


def test_the_bounds_stay_on_the_scale_and_an_unknown_level_is_fixed_at_medium(walking):
    fast = _with(walking, tempo="fast", amplitude="small")
    nominal, low, high = bounds(fast)
    assert nominal.tolist() == [2.0, 0.0, 0.0, 0.0]
    assert low.tolist() == [1.0, 0.0, -15.0, -15.0] and high.tolist() == [2.0, 1.0, 15.0, 15.0]
    unknown = _with(walking, tempo="unknown")
    assert unknown.tempo_level() is None
    nominal, low, high = bounds(unknown)
    assert nominal[0] == low[0] == high[0] == 1.0  # a variant field without a level does not move


def test_realize_rewrites_only_the_levels_that_change(walking):
    smp = _with(walking, tempo="fast", amplitude="medium")
    same, _ = realize(smp, {"tempo": 2.0, "amplitude": 1.0})
    assert same.execution_attributes.tempo == "fast" and same.execution_attributes.amplitude == "medium"
    moved, _ = realize(smp, {"tempo": 2.0, "amplitude": 1.4})
    assert moved.execution_attributes.tempo == "fast" and moved.execution_attributes.amplitude == 1.4
    slower, _ = realize(smp, {"tempo": 1.0})  # the amplitude's level, not the tempo's: it changes
    assert slower.tempo_level() == 1.0
    fine, _ = realize(smp, {"amplitude": 1.23456})
    assert fine.execution_attributes.amplitude == 1.2346  # levels to 4 decimals
    unknown = _with(walking, tempo="unknown")
    kept, _ = realize(unknown, {"tempo": 1.0})  # an unknown level counts as medium
    assert kept.execution_attributes.tempo == "unknown"


def test_a_class_that_cannot_be_fitted_says_why(walking):
    job = job_for(walking, real_windows(walking, {}, seed=2))
    assert fit_class_motion(MotionFitJob(**{**job.__dict__, "smp_json": ""})) == {
        "fitted": False, "reason": "the class's source is not an SMP", "d_stat_windows": job.n_windows}
    assert fit_class_motion(MotionFitJob(**{**job.__dict__, "backend": "hymotion"})) == {
        "fitted": False, "reason": "the hymotion backend has no motion parameters", "d_stat_windows": job.n_windows}


def test_exactly_min_fit_windows_are_enough_and_the_count_alone_decides(walking):
    windows = real_windows(walking, {}, seed=2)[:MIN_FIT_WINDOWS]
    job = job_for(walking, windows)
    assert job.n_windows == MIN_FIT_WINDOWS and job.locations[0].target is not None
    assert fit_class_motion(job)["fitted"]
    fewer = MotionFitJob(**{**job.__dict__, "n_windows": MIN_FIT_WINDOWS - 1})  # targets present, count short
    assert not fit_class_motion(fewer)["fitted"]


def test_the_cem_searches_within_the_bounds_and_keeps_fixed_parameters_still(walking, monkeypatch):
    """On a known landscape (a bowl whose pitch optimum lies below the bound), the fit's CEM keeps every
    candidate in bounds, never spreads a fixed parameter, and finds the free optimum."""
    from vsmp_imu.grounding.calibrate import MIN_STD_FRACTION
    from vsmp_imu.pipeline import motionfit

    optimum, scale = np.array([-5.0, 1.0, -5.0, 5.1234567]), np.array([1.0, 1.0, 10.0, 10.0])

    scored = []

    class Bowl:
        def __init__(self, job, smp):
            pass

        def __call__(self, phis):
            scored.append(phis)
            return (((phis - optimum) / scale) ** 2).sum(axis=1)

    monkeypatch.setattr(motionfit, "_Objective", Bowl)
    d = walking.model_dump(mode="json")
    d["constraints"]["variant_fields"] = ["tempo"]  # amplitude fixed
    d["execution_attributes"]["tempo"] = "slow"  # level 0: the tempo optimum lies below its lower bound
    slow = type(walking).model_validate(d)
    job = job_for(slow, real_windows(walking, {}, seed=2))
    fit = fit_class_motion(job)
    assert fit["evaluations"] == 1 + motionfit.N_ITERATIONS * motionfit.N_CANDIDATES
    assert (fit["low"][:2], fit["high"][:2]) == ([0.0, 1.0], [1.0, 1.0])
    assert fit["std"][1] == 0.0 and fit["mean"][1] == fit["nominal"][1] == 1.0
    floor = MIN_STD_FRACTION * (np.array(fit["high"]) - np.array(fit["low"]))
    assert fit["best"][0] == 0.0 and fit["mean"][0] >= 0.0  # pressed against the bound, not past it
    assert abs(fit["mean"][3] - 5.0) < 1.0 and fit["mean"][2] < 0.0  # toward the free optimum
    assert fit["std"][0] == pytest.approx(MIN_STD_FRACTION)  # collapsed onto the bound: the floor holds it open
    # the kept distribution: mean and spread of the best quarter (10 of 41) of every candidate scored
    phis = np.concatenate(scored)
    losses = Bowl(None, None)(phis)
    elite = phis[np.argsort(losses, kind="stable")[:10]]
    assert fit["mean"] == pytest.approx(elite.mean(0), abs=1e-6)
    assert fit["std"] == pytest.approx(np.maximum(elite.std(0), floor), abs=1e-6)
    assert fit["best"] == pytest.approx(phis[np.argmin(losses)], abs=1e-6)
    assert fit["loss_best"] == round(float(losses.min()), 6) and fit["loss_best"] != round(float(losses.min()), 7)
    assert fit["loss_nominal"] == round(float(losses[0]), 6) != round(float(losses[0]), 7)
    assert fit["d_stat_windows"] == job.n_windows
    assert (np.array(fit["std"]) >= floor - 1e-9).all()
    assert fit["loss_nominal"] == pytest.approx(float(Bowl(None, None)(np.array([fit["nominal"]]))[0]), abs=1e-6)
