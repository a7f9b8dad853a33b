"""The application layer: what the `vsmp-imu` commands do, callable without the command line.

The command line parses options, builds a `GenerationSpec` (and the other
requests below) and calls one function here; everything else (loading the
dataset, assembling a fold, the method registry, the evaluation, the demo)
happens here or further down.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.pipeline.spec import GenerationSpec


# -- one fold (`vsmp-imu generate`) ---------------------------------------------------------------
@dataclass(frozen=True)
class FoldRequest:
    """One LOPO fold to generate: the dataset, the held-out subject and the windowing."""

    dataset: str
    holdout: str
    output: Path
    seed: int = 0
    window_s: float = 2.0
    overlap: float = 0.5
    data_dir: Path | None = None
    save_motions: bool = True


@dataclass
class FoldPlan:
    """A fold assembled for generation: its real training side, budget and base SMPs."""

    info: Any  # DatasetInfo
    train: Any  # Windows of the training subjects
    subjects: list[str]
    budget: Any  # np.ndarray, windows per class
    sources: dict[str, list]
    library: Any  # ActivityLibrary
    warnings: list[str] = field(default_factory=list)  # the dataset's convention warnings


def plan_fold(spec: GenerationSpec, request: FoldRequest) -> FoldPlan:
    """Load the dataset, drop the held-out subject and work out the budget and the sources."""
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.holdout import require_holdout, require_windows
    from vsmp_imu.har.synthetic import ALPHA_RANGE, synthetic_budget
    from vsmp_imu.pipeline.method import make_smp_source
    from vsmp_imu.smp.library import ActivityLibrary

    if not ALPHA_RANGE[0] <= spec.alpha <= ALPHA_RANGE[1]:
        raise ConfigError(f"alpha {spec.alpha} out of range", field="--alpha",
                          allowed=f"{ALPHA_RANGE[0]}..{ALPHA_RANGE[1]}")
    ds = load_dataset(request.dataset, request.data_dir)
    windows = ds.windows(request.window_s, request.overlap)
    require_windows(ds, windows, request.window_s)
    require_holdout(ds, windows, request.holdout, request.window_s)
    check_level_parts(spec, windows.X.shape[1], request.window_s, ds.info.fs_hz)
    subjects = windows.unique_subjects()
    train = windows.where_subjects([request.holdout], keep=False)
    budget = synthetic_budget(train.class_counts(), spec.alpha, spec.policy)
    library = ActivityLibrary.load([Path(d) for d in spec.library_dirs])
    with naming_dataset(request.dataset):
        sources = make_smp_source(spec.source, library).smps(ds.info.name, ds.info.label_names)
    return FoldPlan(ds.info, train, subjects, budget, sources, library, list(ds.warnings))


def check_level_parts(spec: GenerationSpec, size: int, window_s: float, fs_hz: float) -> None:
    """Window levels per part need a sample in every part of a window of `size` samples."""
    if spec.window_levels and spec.level_parts > size:
        raise ConfigError(f"{spec.level_parts} parts of a window of {window_s:g} s at {fs_hz:g} Hz ({size} samples) "
                          "leave some part without a sample", field="--level-parts", allowed=f"1..{size}")


@contextmanager
def naming_dataset(dataset: str):
    """A class that links to no activity file is a mistake in the user's dataset file: name it."""
    try:
        yield
    except ConfigError as exc:
        if exc.file is None and Path(dataset).is_file():
            raise ConfigError(exc.message, file=dataset, field="labels", allowed=exc.allowed) from exc
        raise


def check_sources(spec: GenerationSpec, methods, ds, dataset: str) -> None:
    """Before any work: every class of the dataset has a base SMP for the VSMP methods (library or
    smp:DIR sources; video sources are extracted during the run)."""
    from vsmp_imu.methods import REGISTRY
    from vsmp_imu.pipeline.method import make_smp_source
    from vsmp_imu.smp.library import ActivityLibrary

    if spec.source.startswith("video") or not any(
            REGISTRY.get(name) is not None and REGISTRY[name].kind == "vsmp" for name in methods):
        return
    library = ActivityLibrary.load([Path(d) for d in spec.library_dirs])
    with naming_dataset(dataset):
        make_smp_source(spec.source, library).smps(ds.info.name, ds.info.label_names)


def generate_fold(spec: GenerationSpec, request: FoldRequest, plan: FoldPlan | None = None):
    """Algorithm 1 for one held-out subject, written to `request.output` (returns the FoldOutput)."""
    from vsmp_imu.io import remove_stale_temps
    from vsmp_imu.pipeline.fold import FoldGenerator
    from vsmp_imu.pipeline.output import claim_output, write_output

    plan = plan or plan_fold(spec, request)
    output = request.output
    claim_output(output, plan.info.name, request.holdout)  # refuses a folder of anything else
    cache = Path(spec.cache_dir) if spec.cache_dir else output / "cache"
    for folder in (output, cache):  # leftovers of a killed run
        remove_stale_temps(folder)
    motion_dir = output / "motions" if request.save_motions else None
    generator = FoldGenerator(spec, spec.make_executor(), cache, motion_dir, library=plan.library)
    out = generator.generate(plan.info, plan.train, plan.sources, plan.budget, request.seed,
                             f"holdout-{request.holdout}")
    write_output(output, out, {
        "dataset": plan.info.name, "holdout": request.holdout, "alpha": spec.alpha, "policy": spec.policy,
        "seed": request.seed, "source": spec.source, "config": spec.pipeline_dict(),
        "train_subjects": [s for s in plan.subjects if s != request.holdout],
    })
    return out


# -- an evaluation (`vsmp-imu evaluate`) ----------------------------------------------------------
@dataclass(frozen=True)
class EvalRequest:
    """An evaluation as the command line states it (checked by `EvalConfig`)."""

    dataset: str
    output: Path
    protocol: str = "lopo"
    budgets: tuple[float | None, ...] = (None,)
    backbones: tuple[str, ...] = ("rf",)
    methods: tuple[str, ...] = ("real",)
    folds: tuple[str, ...] | None = None
    seeds: int = 1
    only_seeds: tuple[int, ...] = ()  # run only these of 0..seeds-1 (one evaluation over processes)
    rho: float = 10.0
    window_s: float = 2.0
    overlap: float = 0.5
    data_dir: Path | None = None
    backbone_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    report_groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    unseen: tuple[str, ...] = ()  # unseen protocol: classes, group names or ("each",)
    # do no harm (`vsmp_imu.har.noharm`): off | method | class | amount; the API mixes every
    # synthetic window unless asked, as the paper does; `evaluate` resolves its own default
    # (`cli.har.share_default`: class under lopo, long-tail and unseen with the forests)
    share_selection: str = "off"
    # None: windows weigh as their backbone's class weight says; S: a class's synthetic windows
    # together S times its real ones (`vsmp_imu.har.weights`; needs --class-weight balanced)
    synthetic_weight: float | None = None
    # per method, parameters of its own beside the spec's (imugpt's describer_url and
    # describer_model): recorded in its method_params, so part of the run's settings
    method_options: dict[str, dict[str, Any]] = field(default_factory=dict)


def evaluation(spec: GenerationSpec, request: EvalRequest):
    """The `Evaluation` of a request (dataset loaded, settings checked).

    The generative methods get the spec's options (`vsmp_imu.methods`), with the per-sample
    cache in the cache directory (`vsmp_imu.har.cache.samples_dir()`) unless the spec names one.
    """
    from vsmp_imu.har.cache import max_cache_bytes, samples_dir
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.evaluate import EvalConfig, Evaluation
    from vsmp_imu.har.windows import window_geometry
    from vsmp_imu.methods import method_params, register_all

    register_all()
    seeds = _seeds(request)
    max_cache_bytes()  # a malformed cap fails before any work
    if spec.cache_dir is None:
        spec = replace(spec, cache_dir=str(samples_dir()))
    params = method_params(request.methods, spec)
    for name, options in request.method_options.items():
        if name in params:
            params[name] = {**params[name], **options}
    ds = load_dataset(request.dataset, request.data_dir)
    size, _ = window_geometry(ds.info.fs_hz, request.window_s, request.overlap)  # range checks before any work
    check_level_parts(spec, size, request.window_s, ds.info.fs_hz)
    check_sources(spec, request.methods, ds, request.dataset)
    config = EvalConfig(
        dataset=ds.info.name, protocol=request.protocol, budgets=request.budgets, backbones=request.backbones,
        methods=request.methods, folds=request.folds, seeds=seeds, alpha=spec.alpha,
        policy=spec.policy, rho=request.rho, window_s=request.window_s, overlap=request.overlap,
        backbone_params=request.backbone_params, method_params=params, report_groups=request.report_groups,
        unseen=request.unseen,
        share_selection=request.share_selection, synthetic_weight=request.synthetic_weight,
    )
    return Evaluation(config, ds, request.output)


def _seeds(request: EvalRequest) -> tuple[int, ...]:
    """Seeds 0..N-1 of `--seeds N`, or those of them `--only-seeds` names."""
    seeds = tuple(range(request.seeds))
    if not request.only_seeds:
        return seeds
    outside = [str(s) for s in request.only_seeds if s not in seeds]
    if outside:
        raise ConfigError(f"seed {', '.join(outside)} is not one of --seeds {request.seeds}",
                          field="--only-seeds", allowed=f"seeds 0..{request.seeds - 1}")
    return request.only_seeds


def evaluate(evaluation, progress: Callable | None = None):
    """Run an evaluation and write results.json, results.md and the confusion matrices.

    Returns (EvalResults, written report files)."""
    from vsmp_imu.har.report import write_report

    results = evaluation.run(progress)
    written = write_report(results.to_json(), evaluation.output_dir)
    prune_samples(evaluation.config.method_params)
    return results, written


def prune_samples(method_params: dict[str, dict[str, Any]]) -> None:
    """Keep the sample caches below the size cap (`max_cache_bytes`): the default one whole, and
    a `--cache-dir` the methods were given, of which only the cache's own files are removed."""
    from vsmp_imu.har.cache import max_cache_bytes, prune_cache, prune_files, samples_dir
    from vsmp_imu.pipeline.sample import cached_files

    cap, default = max_cache_bytes(), samples_dir()
    if default.is_dir():
        prune_cache(default, cap)
    for folder in {str(p["cache_dir"]) for p in method_params.values() if p.get("cache_dir")}:
        if Path(folder).absolute() != default.absolute():
            prune_files(cached_files(folder), cap)


def method_names() -> tuple[str, ...]:
    """Every method an evaluation can name."""
    from vsmp_imu.har.synthetic import METHODS
    from vsmp_imu.methods import register_all

    register_all()
    return tuple(METHODS)


# -- the demo (`vsmp-imu demo`) --------------------------------------------------------------------
def run_demo(output: Path, cfg, progress: Callable | None = None) -> dict[str, Any]:
    """The main job on the embedded default (`vsmp_imu.demo.DemoConfig`; see `vsmp_imu.demo`)."""
    from vsmp_imu.demo import run_demo as run

    return run(output, cfg, progress)
