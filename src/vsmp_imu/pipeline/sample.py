"""One synthetic sample of Algorithm 1, up to convention alignment.

For one SMP variant S(k) and seed: verbalize, synthesize the motion M(k),
sample the nominal sensor theta(k) ~ p(theta) for every target location
(mounting perturbation from the grounding prior), simulate the segment
kinematics once, calibrate eta(k)* against D_stat (simulation-in-the-loop),
and align the optimized signal to the target convention gamma. Rank grounding
and the quality filter need the whole fold's samples and run afterwards.

`synthesize(task)` is a top-level function of picklable arguments so any
executor (process pool, Ray) can run it; its result depends on the task only.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import re
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pydantic
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import SampleError, VsmpError
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter
from vsmp_imu.grounding import cadence
from vsmp_imu.grounding.align import Convention, ConventionAlignment, sample_mounting_perturbation
from vsmp_imu.grounding.calibrate import CalibrationResult, CemProblem, SimInTheLoopCalibrator
from vsmp_imu.grounding.durations import scale_for
from vsmp_imu.grounding.stats import StatSummary
from vsmp_imu.grounding.texture import add_texture
from vsmp_imu.imu import (
    ImuNoise,
    SegmentKinematics,
    VirtualSensor,
    draw_noise,
    sensor_readings,
    simulate_kinematics,
)
from vsmp_imu.io import file_name_part, write_bytes
from vsmp_imu.motion import Motion
from vsmp_imu.pipeline.records import LocationProvenance, MotionSummary, Provenance
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import SMP

PIPELINE_VERSION = "1"
# Code whose changes invalidate cached samples: the rooms a sample passes through, and the
# package's top-level modules (seeding, quantiles, units, ...) that those rooms import.
_CODE_ROOMS = ("smp", "motion", "imu", "grounding", "filtering", "pipeline")
# The built-in activity files are data, not code: a sample's key holds the digest of the library
# entry it was made from (SampleTask.content_hash), so an edited file recomputes its class only.
_ACTIVITY_FILES = Path("smp", "activities")


def source_fingerprint(root: Path) -> str:
    """A hash of the package sources under `root` a sample depends on: every .py and .yaml
    file of the rooms but the activity files, and the .py files directly in `root`."""
    digest = hashlib.sha256(PIPELINE_VERSION.encode())
    files = sorted(root.glob("*.py")) + [path for room in _CODE_ROOMS for path in sorted((root / room).rglob("*"))]
    for path in files:
        if path.relative_to(root).is_relative_to(_ACTIVITY_FILES):
            continue
        if path.suffix in (".py", ".yaml") and path.is_file():
            digest.update(str(path.relative_to(root)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """This installation's `source_fingerprint` (part of every sample's cache key)."""
    return source_fingerprint(Path(__file__).resolve().parents[1])


@dataclass(frozen=True)
class LocationTask:
    """One target sensor location: its convention and the D_stat target of the sample's class."""

    name: str
    convention: dict[str, Any]  # Convention.as_dict()
    axes_declared: bool
    target: dict[str, list] | None  # StatSummary arrays as lists (None: no calibration)
    nominal_mounting_xyzw: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)

    def stat_summary(self) -> StatSummary | None:
        if self.target is None:
            return None
        return StatSummary(**{k: np.asarray(v) for k, v in self.target.items()})


@dataclass(frozen=True)
class SampleTask:
    """Everything one sample depends on (its content hash is the cache key)."""

    key: str  # stable name: fold/class/slot
    label: str
    label_index: int
    source: str  # where the SMP came from (library:<name>, file, clip)
    variant: int
    smp_json: str  # the SMP variant; empty when the sample comes from a prompt or a recorded motion
    prompt: str  # the verbalized SMP, or the free-text prompt to generate from
    backend: str
    seed: int
    fs_hz: float
    locations: tuple[LocationTask, ...]
    sim_in_the_loop: bool = True
    noise: bool = True
    duration_s: float | None = None
    library_dirs: tuple[str, ...] = ()
    motion_file: str | None = None  # a recorded motion (.npz, e.g. from video pose) used as is
    motion_digest: str | None = None  # content hash of motion_file (what the cache key sees)
    motion_dir: str | None = None  # where to save the motion (.npz), if anywhere; not hashed
    motion_fit: str = ""  # the class's fitted motion parameters (pipeline.motionfit, JSON; empty: none)
    class_windows: int | None = None  # real training windows of the class in the fold (0: no evidence)
    # the movement texture (grounding.texture), added by the worker: {"seed", "fold"} (its noise is
    # drawn from rng_for(seed, fold, key, "texture")) and "kappa" per location (None: none fitted)
    texture: dict[str, Any] | None = None
    # a real event's duration (grounding.durations): the motion is timed so that its active span
    # lasts this long; None: the SMP's own timing
    event_duration_s: float | None = None
    # a real window's step rate in Hz (grounding.cadence): a gait's cycle is timed to step at this
    # rate; None: the SMP's own tempo
    cadence_hz: float | None = None

    def content_hash(self) -> str:
        payload = asdict(self)
        payload.pop("motion_dir")
        payload.pop("motion_file")
        payload.pop("library_dirs")  # where the activity files lie; what they say is "activity"
        payload["activity"] = self.activity_digest()
        payload["code"] = code_fingerprint()
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:24]

    def activity_digest(self) -> str:
        """What the sample reads from the activity library, as a hash (`ActivityLibrary.digest`):
        the entry its SMP's label names, or the whole library for a prompt; none for a recorded
        motion. It comes from the library the backend animates with (`library_for`)."""
        if self.motion_file:
            return ""
        try:
            label = json.loads(self.smp_json).get("activity_label") if self.smp_json else None
        except (ValueError, AttributeError):  # not an SMP: synthesize reports it; the key reads everything
            label = None
        return library_for(self.library_dirs).digest(label if isinstance(label, str) else None)


@dataclass
class SampleResult:
    """Aligned (not yet grounded) signals of one sample and its provenance."""

    key: str
    label_index: int
    signals: dict[str, np.ndarray]  # location -> (T, 6) in the target convention
    provenance: Provenance
    error: str | None = None

    def to_parquet(self, path: Path) -> None:
        """One shard: a row per location (signal as float64 list + shape); meta in the schema."""
        names = sorted(self.signals)
        signals = [np.ascontiguousarray(self.signals[k], np.float64) for k in names]
        meta = json.dumps({"key": self.key, "label_index": self.label_index,
                           "provenance": self.provenance.as_dict(), "error": self.error},
                          sort_keys=True, default=json_default)
        table = pa.table({
            "location": pa.array(names, pa.string()),
            "n_frames": pa.array([s.shape[0] for s in signals], pa.int64()),
            "n_channels": pa.array([s.shape[1] if s.ndim == 2 else 0 for s in signals], pa.int64()),
            "signal": pa.array([s.ravel() for s in signals], pa.list_(pa.float64())),
        }).replace_schema_metadata({"vsmp_imu.sample": meta})
        buf = io.BytesIO()
        pq.write_table(table, buf, compression="zstd")
        write_bytes(path, buf.getvalue())

    @classmethod
    def from_parquet(cls, path: Path) -> SampleResult:
        table = pq.read_table(path)
        meta = json.loads(table.schema.metadata[b"vsmp_imu.sample"])
        cols = table.to_pydict()
        signals = {
            loc: np.asarray(sig, np.float64).reshape(n, c) if c else np.asarray(sig, np.float64)
            for loc, n, c, sig in zip(cols["location"], cols["n_frames"], cols["n_channels"], cols["signal"],
                                      strict=True)
        }
        return cls(meta["key"], meta["label_index"], signals, Provenance.from_dict(meta["provenance"]),
                   meta["error"])


def json_default(value: Any) -> Any:
    """JSON for numpy scalars and arrays in provenance records."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


_BACKENDS: dict[tuple, tuple[Any, Any]] = {}  # (backend name, folders) -> (its library, the backend)
_LIBRARIES: dict[tuple[str, ...], tuple[float, tuple, Any]] = {}  # folders -> (checked at, signature, library)
# how often a process looks whether an activity file changed since it loaded its library: each look
# stats every file (about 0.5 ms for the built-in folder), and a library is asked for once per sample
LIBRARY_RECHECK_S = 1.0


def library_for(library_dirs: tuple[str, ...]):
    """The activity library of a process: what its backends animate, and what the samples' cache
    keys digest. Loaded once, and again when a file in its folders (built-in or `--library`)
    changed, added or removed, which it looks for at most every `LIBRARY_RECHECK_S` seconds: a
    long-lived session that edits an activity file animates and keys the edit."""
    from vsmp_imu.smp.library import ActivityLibrary, library_signature

    now = time.monotonic()
    held = _LIBRARIES.get(library_dirs)
    if held is not None and now - held[0] < LIBRARY_RECHECK_S:
        return held[2]
    signature = library_signature([Path(d) for d in library_dirs])
    library = held[2] if held is not None and held[1] == signature else \
        ActivityLibrary.load([Path(d) for d in library_dirs])
    _LIBRARIES[library_dirs] = (now, signature, library)
    return library


def forget_libraries() -> None:
    """Drop the process's libraries and backends: the next use loads the folders as they are."""
    _LIBRARIES.clear()
    _BACKENDS.clear()


def backend_for(name: str, library_dirs: tuple[str, ...]):
    """One backend per process and library, on `library_for`'s library (a new one after an edit)."""
    key, library = (name, library_dirs), library_for(library_dirs)
    if key not in _BACKENDS or _BACKENDS[key][0] is not library:
        from vsmp_imu.motion.backends import get_backend

        _BACKENDS[key] = (library, get_backend(name, library=library))
    return _BACKENDS[key][1]


ACTIVE_SPEED_FRACTION = 0.20  # of the peak body speed (appendix: velocity landmarks at 20 %)


def active_span(motion: Motion) -> list[float]:
    """[start, end] seconds between which the body moves (mean joint speed above 20 % of its peak).

    Root translation is removed first, so travelling counts only through the limbs.
    """
    rel = motion.positions - motion.positions[:, :1]
    speed = np.linalg.norm(np.gradient(rel, axis=0), axis=-1).mean(axis=1) * motion.fps
    moving = np.flatnonzero(speed > ACTIVE_SPEED_FRACTION * speed.max()) if speed.max() > 0 else []
    if len(moving) == 0:
        return [0.0, motion.duration_s]
    return [float(moving[0] / motion.fps), float(moving[-1] / motion.fps)]


@dataclass
class _Location:
    """One location of a sample between its kinematics and its calibrated readings."""

    loc: LocationTask
    perturbation: Rotation
    base: np.ndarray
    kin: SegmentKinematics
    noise: ImuNoise | None
    conv: Convention
    theta: dict
    problem: CemProblem | None  # the CEM to run (None: no calibration)


def _prepare_location(motion: Motion, task: SampleTask, loc: LocationTask) -> _Location:
    """theta ~ p(theta) and the kinematics once; the CEM against D_stat is left to run."""
    rng = rng_for(task.seed, "sensor", loc.name)
    sensor = VirtualSensor.at(loc.name)
    perturbation = sample_mounting_perturbation(loc.name, rng)
    nominal = Rotation.from_quat(loc.nominal_mounting_xyzw)
    base = perturbation.as_matrix() @ nominal.as_matrix() @ sensor.mounting_matrix()
    kin = simulate_kinematics(motion, sensor, task.fs_hz)
    noise = draw_noise(sensor, kin.n_samples, task.fs_hz, task.seed, loc.name) if task.noise else None
    conv = Convention(**loc.convention)
    target = loc.stat_summary()
    problem = CemProblem(kin, target, conv, rng, base, noise) if task.sim_in_the_loop and target is not None else None
    return _Location(loc, perturbation, base, kin, noise, conv, sensor.theta(motion, kin.attachment_m), problem)


def _finish_location(state: _Location, result: CalibrationResult | None) -> tuple[np.ndarray, LocationProvenance]:
    """The calibrated (or nominal) readings, aligned with A_gamma, and the location's record."""
    if result is not None:
        readings, gravity, eta = result.readings, result.gravity, result.as_dict()
    else:
        readings = sensor_readings(state.kin, state.base, None, None, 1.0, 1.0, True, state.noise)[0]
        gravity, eta = state.kin.grav_seg @ state.base.T, None
    record = LocationProvenance(
        start_s=float(state.kin.times[0]), theta=state.theta,
        mounting_perturbation_xyzw=[float(v) for v in state.perturbation.as_quat()],
        nominal_mounting_xyzw=list(state.loc.nominal_mounting_xyzw), eta=eta, gamma=state.conv.as_dict())
    return ConventionAlignment(state.conv).transform(readings, gravity), record


def _motion(task: SampleTask) -> tuple[Motion, str | None]:
    """The sample's motion: a recorded one, or generated from the SMP variant or the prompt."""
    if task.motion_file:
        motion, smp_id = Motion.load(task.motion_file), None
    elif task.smp_json:
        try:
            smp = SMP.model_validate_json(task.smp_json)
        except pydantic.ValidationError as exc:
            raise SampleError(f"the SMP variant has {exc.error_count()} field(s) out of range: "
                              f"{exc.errors()[0]['msg']}", field="smp") from exc
        motion, smp_id = _smp_motion(task, smp), smp.smp_id
    else:
        motion, smp_id = backend_for(task.backend, task.library_dirs).generate(task.prompt, task.seed,
                                                                               task.duration_s), None
    if not (np.isfinite(motion.positions).all() and np.isfinite(motion.rotations).all()):
        raise SampleError("the motion has non-finite joint positions or rotations", field="motion")
    return motion, smp_id


def _smp_motion(task: SampleTask, smp: SMP) -> Motion:
    """The SMP variant's motion; with a class motion fit, with this sample's draw of its parameters."""
    backend = backend_for(task.backend, task.library_dirs)
    if not task.motion_fit:
        return _timed(backend, smp, task, {})
    from vsmp_imu.pipeline.motionfit import draw, realize

    phi = draw(json.loads(task.motion_fit), task.seed)
    fitted, offsets = realize(smp, phi)
    motion = _timed(backend, fitted, task, offsets)
    motion.meta.setdefault("controls", {})["motion_fit"] = phi
    return motion


def _timed(backend, smp: SMP, task: SampleTask, offsets: dict[str, float]) -> Motion:
    """The motion; with `task.cadence_hz`, stepping at that rate (`_cadenced`); with
    `task.event_duration_s`, generated again with its primitives' durations scaled so that its
    active span lasts that long (grounding.durations)."""
    extra = {"offsets_deg": offsets} if offsets else {}
    if task.cadence_hz is not None:
        return _cadenced(backend, smp, task, extra)
    motion = backend.generate(smp, task.seed, task.duration_s, **extra)
    if task.event_duration_s is None:
        return motion
    start, end = active_span(motion)
    scale = scale_for(task.event_duration_s, end - start)
    motion = backend.generate(smp, task.seed, task.duration_s, duration_scale=scale, **extra)
    motion.meta.setdefault("controls", {})["event_duration"] = {
        "target_s": round(float(task.event_duration_s), 4), "nominal_active_s": round(end - start, 4),
        "scale": round(scale, 6)}
    return motion


def _cadenced(backend, smp: SMP, task: SampleTask, extra: dict) -> Motion:
    """The gait's motion with every duration scaled so that it steps at `task.cadence_hz`
    (grounding.cadence): its plan's cycle holds two steps when the recipe alternates the legs."""
    plan = backend.plan(smp, task.seed, task.duration_s)
    cycle = plan.recipe.cycle
    steps = 2 if cycle is not None and cycle.alternate else 1
    scale = cadence.scale_for(task.cadence_hz, steps, plan.cycle_s)
    motion = backend.generate(smp, task.seed, task.duration_s, duration_scale=scale, **extra)
    motion.meta.setdefault("controls", {})["cadence"] = {
        "target_hz": round(float(task.cadence_hz), 4), "nominal_hz": round(steps / plan.cycle_s, 4),
        "scale": round(scale, 6)}
    return motion


def synthesize(task: SampleTask, motion_path: Path | None = None) -> SampleResult:
    """Run the per-sample part of Algorithm 1. A declared sample-level failure (a `VsmpError`:
    a prompt that names no activity, a non-finite motion, a field out of range, see
    `SampleError`) becomes the result's error string; any other exception is a bug and is
    raised, failing the run with its traceback.

    The motion is saved to `motion_path` when given.
    """
    return synthesize_many([task], [motion_path])[0]


def synthesize_many(tasks: list[SampleTask], motion_paths: list[Path | None]) -> list[SampleResult]:
    """`synthesize` for several samples, each with the result it gets alone: their motions and
    kinematics one by one, then the CEMs of all their locations in lockstep
    (`SimInTheLoopCalibrator.calibrate_many`), then each sample's signals."""
    results: list[SampleResult | None] = [None] * len(tasks)
    pending: dict[int, tuple] = {}
    for i, (task, path) in enumerate(zip(tasks, motion_paths, strict=True)):
        try:
            pending[i] = _prepare(task, path)
        except VsmpError as exc:  # a failed sample is recorded and filtered out
            results[i] = _failed(task, exc)
    problems = [st.problem for *_, locations in pending.values() for st in locations if st.problem is not None]
    # in the same order as the problems were listed
    calibrated = iter(SimInTheLoopCalibrator(search_gravity=False).calibrate_many(problems) if problems else [])
    for i, (smp_id, verdict, summary, locations) in pending.items():
        task = tasks[i]
        fits = [next(calibrated) if st.problem is not None else None for st in locations]
        try:
            signals, records = {}, {}
            for st, fit in zip(locations, fits, strict=True):
                signals[st.loc.name], records[st.loc.name] = _finish_location(st, fit)
            if task.texture:
                signals = _textured(signals, task)
            provenance = Provenance(task.source, task.label, task.variant, smp_id, task.prompt, task.backend,
                                    task.seed, summary, verdict, records, task.class_windows)
            results[i] = SampleResult(task.key, task.label_index, signals, provenance)
        except VsmpError as exc:
            results[i] = _failed(task, exc)
    return results


def _prepare(task: SampleTask, motion_path: Path | None) -> tuple:
    """A sample up to its CEMs: (SMP id, motion verdict, motion summary, its locations)."""
    motion, smp_id = _motion(task)
    motion_verdict = MotionPlausibilityFilter().check_motion(motion)
    summary = MotionSummary(fps=motion.fps, n_frames=motion.n_frames, duration_s=motion.duration_s,
                            body_height_m=motion.body_height_m(), active_span_s=active_span(motion),
                            controls=motion.meta.get("controls"))
    if motion_path is not None:
        motion.meta.update({"sample_key": task.key, "label": task.label})
        motion.save(motion_path)
    return smp_id, motion_verdict, summary, [_prepare_location(motion, task, loc) for loc in task.locations]


def _failed(task: SampleTask, exc: VsmpError) -> SampleResult:
    return SampleResult(task.key, task.label_index, {}, Provenance(task.source, task.label,
                                                                   class_windows=task.class_windows),
                        error=f"{type(exc).__name__}: {exc}")


def _textured(signals: dict[str, np.ndarray], task: SampleTask) -> dict[str, np.ndarray]:
    """The signals with their movement texture, locations in name order from one noise stream."""
    tex = task.texture
    rng = rng_for(tex["seed"], tex["fold"], task.key, "texture")
    return {name: add_texture(sig, tex["kappa"][name], task.fs_hz, rng) if name in tex["kappa"] else sig
            for name, sig in sorted(signals.items())}


def sample_stem(key: str) -> str:
    """The file name (without suffix) of a sample's SMP and motion: its key 'fold/class/slot' as
    'fold__class__slot', the class being the user's text (`file_name_part`)."""
    return file_name_part(key.replace("/", "__"))


def motion_file(task: SampleTask) -> Path | None:
    if not task.motion_dir:
        return None
    return Path(task.motion_dir) / f"{sample_stem(task.key)}.npz"


def cached_synthesize(args: tuple[SampleTask, str | None]) -> SampleResult:
    """`synthesize` with an on-disk cache keyed by the task's content hash.

    The cache entry is the worker's own Parquet shard (`<content hash>.parquet`,
    plus the motion when the task saves motions); the fold merges the results in
    task order, so neither the number of workers nor the order in which they
    finish changes the output, and a resumed run writes the same files as an
    uninterrupted one.
    """
    task, cache_dir = args
    return cached_synthesize_many((task,), cache_dir)[0]


def cached_synthesize_many(tasks: tuple[SampleTask, ...], cache_dir: str | None) -> list[SampleResult]:
    """`cached_synthesize` of several tasks: the cached ones read, the others made together
    (`synthesize_many`: the same results as one by one) and cached."""
    results: list[SampleResult | None] = [_cached(t, cache_dir) for t in tasks]
    todo = [i for i, r in enumerate(results) if r is None]
    paths = [_motion_target(tasks[i], cache_dir) for i in todo]
    for i, path, result in zip(todo, paths, synthesize_many([tasks[i] for i in todo], paths), strict=True):
        out_motion = motion_file(tasks[i])
        if out_motion is not None and path is not None and path != out_motion and path.exists():
            write_bytes(out_motion, path.read_bytes())
        if cache_dir is not None:
            result.to_parquet(Path(cache_dir) / f"{tasks[i].content_hash()}.parquet")
        results[i] = result
    return results


CACHED_NAME = re.compile(r"[0-9a-f]{24}(\.motion\.npz|\.parquet)")  # `_cached`'s files: content hash, kind


def cached_files(cache_dir: str | Path) -> list[Path]:
    """The per-sample cache's own files directly in `cache_dir` (`_cached`), nothing else."""
    folder = Path(cache_dir)
    if not folder.is_dir():
        return []
    return [p for p in folder.iterdir() if CACHED_NAME.fullmatch(p.name) and p.is_file() and not p.is_symlink()]


def _motion_target(task: SampleTask, cache_dir: str | None) -> Path | None:
    """Where a new sample's motion is written: the cache (copied out after), or its own file."""
    out_motion = motion_file(task)
    if cache_dir is None or out_motion is None:
        return out_motion
    return Path(cache_dir) / f"{task.content_hash()}.motion.npz"


def _cached(task: SampleTask, cache_dir: str | None) -> SampleResult | None:
    """The task's cached result (its motion copied out when the task saves motions), or None."""
    if cache_dir is None:
        return None
    digest = task.content_hash()
    path = Path(cache_dir) / f"{digest}.parquet"
    cached_motion = Path(cache_dir) / f"{digest}.motion.npz"
    out_motion = motion_file(task)
    if not path.exists() or (out_motion is not None and not cached_motion.exists()):
        return None
    try:
        result = SampleResult.from_parquet(path)
        os.utime(path)  # recently used: the cache's size cap removes the oldest entries first
        if out_motion is not None and not out_motion.exists():
            write_bytes(out_motion, cached_motion.read_bytes())
        return result
    except Exception:  # a damaged cache entry is recomputed
        path.unlink(missing_ok=True)
        return None
