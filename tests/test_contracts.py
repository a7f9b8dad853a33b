"""One contract for every algorithm class (in the spirit of scikit-learn's estimator checks).

Each class in `CASES` is built from cheap test parameters and checked the same way:

- `__init__` stores each parameter untouched under its own name and does no work
  (no other public attribute, nothing fitted);
- the parameters round-trip: `cls(**params_of(obj))` has the same parameters;
- its one action verb leaves the parameters as they were and puts whatever it
  keeps in attributes whose names end with `_`;
- the same seed gives the same bytes (fresh instances, and the same instance
  twice); where the class draws random numbers, another seed gives other bytes;
- it pickles (the executors send it to workers): the copy gives the same bytes,
  before and after the action.

`test_every_algorithm_class_is_covered` keeps the list whole: a new class with an
action verb in the algorithm rooms must join `CASES` or say in `EXEMPT` why not.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import importlib
import inspect
import pickle
import sys
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import BaseModel
from scipy.spatial.transform import Rotation

from vsmp_imu.baselines.classical import ClassicalAugmentation
from vsmp_imu.extract.calibrate import motion_track
from vsmp_imu.extract.pose import PoseExtractor
from vsmp_imu.extract.posemeasure import PoseMeasurer
from vsmp_imu.extract.retarget import track_to_motion
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter
from vsmp_imu.filtering.validator import HarValidator
from vsmp_imu.grounding.align import Convention, ConventionAlignment
from vsmp_imu.grounding.calibrate import SimInTheLoopCalibrator
from vsmp_imu.grounding.rank import RankGrounder
from vsmp_imu.grounding.stats import segment, summarize_windows
from vsmp_imu.har.backbones import BACKBONES
from vsmp_imu.har.normalize import ChannelStandardizer
from vsmp_imu.imu import (
    ImuSimulator,
    VirtualSensor,
    draw_noise,
    sensor_readings,
    simulate_kinematics,
)
from vsmp_imu.motion.hymotion import HYMotionBackend
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import Refiner
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

# -- shared inputs (small, built once) --------------------------------------------------------


@cache
def library() -> ActivityLibrary:
    return ActivityLibrary.load()


@cache
def motion():
    return ProceduralBackend(library()).generate(library().get("walking").smp, seed=1, duration_s=3.0)


@cache
def windows() -> tuple[np.ndarray, np.ndarray]:
    """60 windows (50 samples, 6 channels) of 3 classes that differ in rhythm and energy."""
    rng = np.random.default_rng(0)
    y = np.repeat(np.arange(3), 20)
    t = np.arange(50) / 50.0
    x = rng.normal(0.0, 0.3, (60, 50, 6))
    x += (1.0 + y)[:, None, None] * np.sin(2 * np.pi * (1.0 + y)[:, None, None] * t[None, :, None])
    x[..., 1] += STANDARD_GRAVITY_M_S2
    return x, y


@cache
def calibration_inputs():
    kin = simulate_kinematics(motion(), "waist", 50.0)
    noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples, 50.0, 0, "sim")
    # the "real" stream is the motion worn 10° rolled, with a bias and more noise: the CEM has
    # something to find, so its candidates (and so its seed) decide the result
    rolled = Rotation.from_euler("z", 10, degrees=True).as_matrix()
    real = sensor_readings(kin, rolled, np.array([0.1, 0.0, -0.1]), None, 1.5, 1.0, True,
                           draw_noise(VirtualSensor.at("waist"), kin.n_samples, 50.0, 1, "real"))[0]
    return kin, noise, summarize_windows(segment(real, 50), 50.0)


@cache
def track():
    return motion_track(motion(), px_per_m=250.0)


class StandInRuntime:
    """HY-Motion's runtime as the backend calls it (same signature and output structure,
    rebuilt from known rotations by tests/motion/test_motion_hymotion.py); keeps no state."""

    def generate_motion(self, text, seeds_csv, duration, cfg_scale, output_format="fbx",
                        output_dir=None, output_filename=None, original_text=None,
                        use_special_game_feat=False):
        sys.path.insert(0, str(Path(__file__).parent / "motion"))
        from test_motion_hymotion import _hy_output

        output = _hy_output(int(seeds_csv))[0]
        return "<html></html>", [], {k: (v[:1] if hasattr(v, "shape") else v) for k, v in output.items()}


# -- the cases ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class Case:
    """How to build one class cheaply and run its action.

    params(seed): constructor arguments; act(obj, seed): runs the verb and returns what it
    produced; seeded: another seed must give other bytes; query(obj): reads what a run
    left in the object (compared across a pickle round trip).
    """

    id: str
    cls: type
    verb: str
    params: Callable[[int], dict[str, Any]]
    act: Callable[[Any, int], Any]
    seeded: bool = False
    query: Callable[[Any], Any] | None = None


def _fit_predict(obj, seed):
    x, y = windows()
    return obj.fit(x, y).predict_proba(x)


def _predict(obj):
    return obj.predict_proba(windows()[0])


def _rank(obj, seed):
    x, y = windows()
    real = x * 1.5 + 0.2
    return obj.fit(x, real, y, y).transform(x, y)


def _plausibility(obj, seed):
    x, y = windows()
    verdicts = obj.fit(x, y).check_windows(x, y)
    return [v.as_dict() for v in verdicts], obj.check_motion(motion()).as_dict()


def _calibrate(obj, seed):
    kin, noise, target = calibration_inputs()
    return obj.calibrate(kin, target, Convention(), np.random.default_rng(seed), noise=noise)


def _classical(obj, seed):
    x = windows()[0][0]
    return obj.augment(x, x.std(axis=0), [[0, 1, 2], [3, 4, 5]], np.random.default_rng(seed))


def _alignment(obj, seed):
    x = windows()[0]
    gravity = np.zeros(x.shape[:-1] + (3,))
    gravity[..., 1] = STANDARD_GRAVITY_M_S2
    return obj.transform(x, gravity)


def _backbone_case(name: str) -> Case:
    cls = BACKBONES[name]
    cheap = {"max_epochs": 1} if "max_epochs" in cls._get_test_params() else {}
    return Case(name, cls, "fit", lambda s: {**cls._get_test_params(), **cheap, "random_state": s},
                _fit_predict, seeded=True, query=_predict)


CASES: list[Case] = [
    Case("procedural", ProceduralBackend, "generate", lambda s: {"library": library(), "fps": 30.0},
         lambda o, s: o.generate(library().get("walking").smp, seed=s, duration_s=2.0), seeded=True),
    Case("hymotion", HYMotionBackend, "generate",
         lambda s: {"runtime": StandInRuntime(), "library": library(), "cfg_scale": 4.0},
         lambda o, s: o.generate("A person waves.", seed=s, duration_s=1.5), seeded=True),
    Case("imu-simulator", ImuSimulator, "simulate", lambda s: {"fs_hz": 50.0, "seed": s},
         lambda o, s: o.simulate(motion(), "right_wrist"), seeded=True,
         query=lambda o: o.kinematics_.grav_seg),
    Case("cem-calibrator", SimInTheLoopCalibrator, "calibrate",
         lambda s: {"n_iterations": 3, "n_candidates": 16}, _calibrate, seeded=True),
    Case("rank-grounder", RankGrounder, "fit", lambda s: {"n_quantiles": 64}, _rank,
         query=lambda o: o.transform(windows()[0])),
    Case("rank-grounder-per-class", RankGrounder, "fit",
         lambda s: {"per_class": True, "min_class_samples": 50, "n_quantiles": 64}, _rank,
         query=lambda o: o.transform(windows()[0], windows()[1])),
    Case("convention-alignment", ConventionAlignment, "transform",
         lambda s: {"convention": Convention(axes=("up", "left", "forward"), gravity_included=False,
                                             acc_unit="g", gyr_unit="deg/s")}, _alignment),
    Case("plausibility-filter", MotionPlausibilityFilter, "fit", lambda s: {"min_class_windows": 10},
         _plausibility, query=lambda o: o.thresholds_for(0).as_dict()),
    Case("har-validator", HarValidator, "fit", lambda s: {"hidden": (8,), "max_iter": 30, "seed": s},
         _fit_predict, seeded=True, query=_predict),
    *[_backbone_case(name) for name in BACKBONES],
    Case("channel-standardizer", ChannelStandardizer, "fit", lambda s: {"eps": 1e-8},
         lambda o, s: o.fit_transform(windows()[0]), query=lambda o: o.transform(windows()[0])),
    Case("classical-augmentation", ClassicalAugmentation, "augment", lambda s: {"p": 0.5}, _classical,
         seeded=True),
    Case("smp-augmenter", SMPAugmenter, "augment", lambda s: {"uncertainty_conditioned": True},
         lambda o, s: o.augment(library().get("jumping_jacks").smp, k=3, seed=s), seeded=True,
         query=lambda o: o.changes_),
    Case("refiner", Refiner, "refine", lambda s: {"library": library()},
         lambda o, s: o.refine(library().get("jumping_jacks").smp)),
    Case("pose-extractor", PoseExtractor, "extract_track", lambda s: {"library": library()},
         lambda o, s: o.extract_track(track(), "jumping_jacks")),
    Case("pose-measurer", PoseMeasurer, "measure", lambda s: {"periodic": True},
         lambda o, s: o.measure(track(), track_to_motion(track()))),
]

# Classes with an action verb in the algorithm rooms that the cases above do not build.
EXEMPT: dict[str, str] = {
    "vsmp_imu.extract.vlm.VLMExtractor": "needs a VLM server (tests/extract/test_vlm.py runs one)",
    "vsmp_imu.extract.pool.SourcePoolFilter": "judges video clips through a checker (tests/extract/test_pool.py)",
    "vsmp_imu.extract.pool.VLMClipChecker": "needs a VLM server (tests/extract/test_pool.py)",
    "vsmp_imu.extract.pool.PoseClipChecker": "needs video clips (tests/extract/test_pool.py)",
    "vsmp_imu.extract.frames.FrameSampler": "reads video files (tests/extract/test_frames.py)",
    "vsmp_imu.extract.landmarks.MediaPipePoseEstimator": "needs the video extra (tests/extract/test_pose_real.py)",
    "vsmp_imu.har.backbones.neural.TorchClassifier": "the neural backbones' base; each subclass has a case",
    "vsmp_imu.baselines.generative.ImuGptMethod": "a whole fold's generation (tests/baselines)",
    "vsmp_imu.baselines.generative.ImuTubeMethod": "a whole fold's generation (tests/baselines)",
}
ROOMS = (
    "vsmp_imu.motion.procedural", "vsmp_imu.motion.hymotion", "vsmp_imu.imu.simulator",
    "vsmp_imu.grounding.align", "vsmp_imu.grounding.calibrate", "vsmp_imu.grounding.rank",
    "vsmp_imu.filtering.plausibility", "vsmp_imu.filtering.validator", "vsmp_imu.filtering.faithfulness",
    "vsmp_imu.har.backbones.rf", "vsmp_imu.har.backbones.neural", "vsmp_imu.har.normalize",
    "vsmp_imu.smp.augment", "vsmp_imu.smp.refine", "vsmp_imu.baselines.classical",
    "vsmp_imu.baselines.generative", "vsmp_imu.extract.pose", "vsmp_imu.extract.posemeasure",
    "vsmp_imu.extract.vlm", "vsmp_imu.extract.pool", "vsmp_imu.extract.frames", "vsmp_imu.extract.landmarks",
)
VERBS = {"fit", "generate", "simulate", "calibrate", "transform", "augment", "refine", "measure",
         "extract", "extract_track", "check", "estimate", "sample"}

# -- helpers -------------------------------------------------------------------------------------


def init_params(cls: type) -> list[str]:
    sig = inspect.signature(cls.__init__)
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [p.name for p in list(sig.parameters.values())[1:] if p.kind in kinds]


def params_of(obj: Any) -> dict[str, Any]:
    """The constructor parameters as the object holds them (scikit-learn's get_params)."""
    return {name: getattr(obj, name) for name in init_params(type(obj))}


def canonical(obj: Any) -> Any:
    """Plain nested tuples of bytes, strings and numbers, equal exactly when the values are."""
    if isinstance(obj, np.ndarray):
        return ("ndarray", obj.dtype.str, obj.shape, np.ascontiguousarray(obj).tobytes())
    if isinstance(obj, np.generic):
        return canonical(np.asarray(obj))
    if isinstance(obj, BaseModel):
        return canonical(obj.model_dump(mode="json"))
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return (type(obj).__name__,
                tuple((f.name, canonical(getattr(obj, f.name))) for f in dataclasses.fields(obj)))
    if isinstance(obj, dict):
        return ("dict", tuple(sorted((repr(k), canonical(v)) for k, v in obj.items())))
    if isinstance(obj, list | tuple):
        return (type(obj).__name__, tuple(canonical(v) for v in obj))
    if isinstance(obj, float):
        return ("float", obj.hex())
    if obj is None or isinstance(obj, bool | int | str | bytes):
        return obj
    state = getattr(obj, "__dict__", None)
    return (type(obj).__name__, repr(obj) if state is None else canonical(dict(state)))


def digest(obj: Any) -> str:
    # repr, not pickle: pickle's bytes also depend on which equal objects are shared
    return hashlib.sha256(repr(canonical(obj)).encode()).hexdigest()


def build(case: Case, seed: int = 0) -> Any:
    return case.cls(**case.params(seed))


def public_state(obj: Any) -> set[str]:
    return {k for k in vars(obj) if not k.startswith("_")}


# -- the contract ----------------------------------------------------------------------------------

def check_init_stores_each_parameter_untouched(case: Case) -> None:
    params = case.params(0)
    obj = case.cls(**params)
    names = init_params(case.cls)
    defaults = {n: p.default for n, p in inspect.signature(case.cls.__init__).parameters.items()}
    for name in names:
        expected = params[name] if name in params else defaults[name]
        assert getattr(obj, name) is expected, f"{case.cls.__name__}.{name} is not the value given"
    extra = public_state(obj) - set(names)
    assert not extra, f"{case.cls.__name__}.__init__ sets more than its parameters: {sorted(extra)}"


def check_parameters_round_trip(case: Case) -> None:
    obj = build(case)
    clone = case.cls(**params_of(obj))
    assert digest(params_of(clone)) == digest(params_of(obj))


def check_action_keeps_parameters_and_results_in_trailing_underscores(case: Case) -> None:
    obj = build(case)
    assert callable(getattr(obj, case.verb, None)), f"{case.cls.__name__} has no verb '{case.verb}'"
    before, before_bytes = params_of(obj), digest(params_of(obj))
    state = public_state(obj)
    case.act(obj, 0)
    after = params_of(obj)
    assert all(after[k] is before[k] for k in before), "the action replaced a parameter"
    assert digest(after) == before_bytes, "the action changed a parameter's value"
    added = public_state(obj) - state
    assert all(k.endswith("_") for k in added), f"results outside trailing-underscore names: {added}"
    if case.query is not None:
        assert added, "a class read through `query` keeps its results in attributes"


def check_same_seed_same_bytes(case: Case) -> None:
    first = digest(case.act(build(case, 3), 3))
    obj = build(case, 3)
    assert digest(case.act(obj, 3)) == first, "two fresh instances differ"
    assert digest(case.act(obj, 3)) == first, "a second run on the same instance differs"
    if case.seeded:
        assert digest(case.act(build(case, 4), 4)) != first, "the seed is not used"


def check_pickles_before_and_after_the_action(case: Case) -> None:
    obj = build(case, 5)
    copy_before = pickle.loads(pickle.dumps(obj))
    assert type(copy_before) is case.cls
    assert digest(case.act(copy_before, 5)) == digest(case.act(obj, 5))
    copy_after = pickle.loads(pickle.dumps(obj))
    if case.query is not None:
        assert digest(case.query(copy_after)) == digest(case.query(obj))
    assert digest(case.act(copy_after, 5)) == digest(case.act(copy.deepcopy(obj), 5))


CHECKS = [
    check_init_stores_each_parameter_untouched,
    check_parameters_round_trip,
    check_action_keeps_parameters_and_results_in_trailing_underscores,
    check_same_seed_same_bytes,
    check_pickles_before_and_after_the_action,
]


@pytest.mark.parametrize("check", CHECKS, ids=lambda c: c.__name__.removeprefix("check_"))
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.id)
def test_contract(case, check):
    check(case)


# -- each check fails on a class that breaks its rule --------------------------------------------


class CopiesItsParameter:
    def __init__(self, hidden=(8,)) -> None:
        self.hidden = list(hidden)

    def fit(self, x):
        return x


class ChangesItsParameter:
    def __init__(self, scale=None) -> None:
        self.scale = scale

    def fit(self, x):
        self.scale = 2.0
        return x


class KeepsAPublicResult:
    def __init__(self, scale=1.0) -> None:
        self.scale = scale

    def fit(self, x):
        self.mean = float(np.mean(x))
        return self.mean


class IgnoresItsSeed:
    def __init__(self, seed=0) -> None:
        self.seed = seed

    def sample(self, n):
        return np.random.default_rng().normal(size=n)


class HoldsALambda:
    def __init__(self, scale=1.0) -> None:
        self.scale = scale
        self._f = lambda v: v * scale

    def transform(self, x):
        return self._f(x)


BROKEN = [
    (check_init_stores_each_parameter_untouched, Case("copies", CopiesItsParameter, "fit",
                                                      lambda s: {"hidden": (8,)}, lambda o, s: o.fit(1.0))),
    (check_action_keeps_parameters_and_results_in_trailing_underscores,
     Case("changes", ChangesItsParameter, "fit", lambda s: {}, lambda o, s: o.fit(1.0))),
    (check_action_keeps_parameters_and_results_in_trailing_underscores,
     Case("public-result", KeepsAPublicResult, "fit", lambda s: {}, lambda o, s: o.fit([1.0, 2.0]))),
    (check_same_seed_same_bytes,
     Case("unseeded", IgnoresItsSeed, "sample", lambda s: {"seed": s}, lambda o, s: o.sample(4))),
    (check_pickles_before_and_after_the_action,
     Case("lambda", HoldsALambda, "transform", lambda s: {}, lambda o, s: o.transform(1.0))),
]


@pytest.mark.parametrize(("check", "case"), BROKEN, ids=lambda v: getattr(v, "id", None))
def test_each_check_catches_a_class_that_breaks_it(check, case):
    with pytest.raises((AssertionError, pickle.PicklingError, AttributeError)):
        check(case)


def test_every_algorithm_class_is_covered():
    covered = {f"{c.cls.__module__}.{c.cls.__qualname__}" for c in CASES}
    missing = []
    for room in ROOMS:
        module = importlib.import_module(room)
        for _, cls in inspect.getmembers(module, inspect.isclass):
            name = f"{cls.__module__}.{cls.__qualname__}"
            if cls.__module__ != room or cls.__name__.startswith("_") or dataclasses.is_dataclass(cls):
                continue
            verbs = {m for m in VERBS if callable(getattr(cls, m, None))}
            if verbs and not issubclass(cls, BaseException) and name not in covered | set(EXEMPT):
                missing.append(f"{name} ({', '.join(sorted(verbs))})")
    assert not missing, "algorithm classes without a contract case: " + "; ".join(missing)
    assert set(EXEMPT).isdisjoint(covered)
