"""`vsmp-imu study ...`: the paper's studies (controllability, extraction audit, case study,
ablations, activity granularity, realism)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import typer

from vsmp_imu.cli.common import (
    DESCRIBER_MODEL_OPTION,
    DESCRIBER_URL_OPTION,
    LIBRARY_OPTION,
    console,
    describer_options,
    finite_list,
    finite_range,
    int_range,
    library_dirs,
    option_group,
    option_names,
    output_dir,
    parse_csv,
    shown,
)
from vsmp_imu.errors import ConfigError
from vsmp_imu.har.protocols import MIN_BUDGET
from vsmp_imu.progress import progress
from vsmp_imu.studies.folders import claim_study_folder, study_folder

study_app = typer.Typer(help="Studies of the paper: end-to-end controllability, SMP extraction "
                        "audit, qualitative case study, ablations, activity granularity, realism.",
                        no_args_is_help=True)
DATASET_HELP = "hapt, hapt12 (ship offline), utd_mhad, pamap2, mmfit, mmact, had-aw (--data-dir) or a .yaml"
DATASET_OPTION = typer.Option("hapt12", "--dataset", "-d", help=DATASET_HELP)
DATA_DIR_OPTION = typer.Option(None, "--data-dir", help="Folder of a downloaded dataset")
BACKBONE_OPTION = typer.Option("rf", "--backbone", help="rf | rf-seg | dclstm | dclstm-attn | bilstm-attn")
BACKEND_OPTION = typer.Option("procedural", "--backend", help="Motion backend: procedural | compiled | hymotion")
# Number options are checked by their callbacks (cli.common's ranges) before any work; the
# integers' upper bounds are generous multiples of what the paper and the defaults use.
SEED_MAX = 2**32 - 1  # numpy's and scikit-learn's seed range
SEEDS_MAX = 1000  # as `evaluate --seeds`
JOBS_MAX = 256  # as `evaluate --jobs` and `--workers`
EPOCHS_MAX = 100_000  # as `evaluate --max-epochs` and `--patience`
K_MAX = 64  # as `evaluate --k`
SEED_RANGE, SEEDS_RANGE, JOBS_RANGE = int_range(0, SEED_MAX), int_range(1, SEEDS_MAX), int_range(1, JOBS_MAX)
EPOCHS_RANGE, K_RANGE = int_range(1, EPOCHS_MAX), int_range(1, K_MAX)
ALPHA_RANGE = finite_range(0.1, 2.0)
BUDGET_RANGE = finite_range(MIN_BUDGET, 100.0)  # a label budget in percent, as evaluate's --budgets
WORKERS_OPTION = typer.Option(1, "--workers", callback=JOBS_RANGE, help=f"Generation workers (1..{JOBS_MAX})")
MAX_EPOCHS_OPTION = typer.Option(None, "--max-epochs", callback=EPOCHS_RANGE,
                                 help=f"Neural backbones: epoch limit (1..{EPOCHS_MAX})")
PATIENCE_OPTION = typer.Option(None, "--patience", callback=EPOCHS_RANGE,
                               help=f"Neural backbones: early stopping (1..{EPOCHS_MAX})")
SOURCE_OPTION = typer.Option("library", "--source", help="VSMP source SMPs: library | smp:DIR | video:DIR")
SEEDS_OPTION = typer.Option(1, "--seeds", callback=SEEDS_RANGE, help=f"Seeds 0..N-1 (N 1..{SEEDS_MAX})")
JOBS_OPTION = typer.Option(None, "--jobs", callback=JOBS_RANGE, help=f"CPU threads of the backbone (1..{JOBS_MAX})")
SEED_HELP = f"(0..{SEED_MAX})"
# what the studies' errors call a setting -> the option that sets it (`option_names`)
GENERATION_OPTIONS = {"backend": "--backend", "source": "--source", "k": "--k", "workers": "--workers"}
CONTROL_OPTIONS = {"backend": "--backend", "activities": "--activities", "controls": "--controls",
                   "seeds": "--seeds"}
CASE_OPTIONS = {"activity": "--activity", "location": "--location"}
FOLDS_OPTION = typer.Option("all", "--folds", help="'all' or held-out subjects, e.g. 1,2,3,4,5")
# The options `ablation` and `granularity` end with: generation (--backend, --workers, --library)
# and the backbone's training; the parameter `run` of each stands for them (`option_group`).
run_options = option_group("run", {
    "backend": (str, BACKEND_OPTION), "workers": (int, WORKERS_OPTION),
    "max_epochs": (int | None, MAX_EPOCHS_OPTION), "patience": (int | None, PATIENCE_OPTION),
    "jobs": (int | None, JOBS_OPTION), "library": (list[Path], LIBRARY_OPTION)})
STUDY_PROTOCOLS = ("lopo", "low-resource", "long-tail")  # the studies' protocols (no unseen, tstr)
PROTOCOL_HELP = " | ".join(STUDY_PROTOCOLS)


def _output(output: Path, study: str) -> None:
    """The output folder: one we may write in, new, empty or the study's own (`claim_study_folder`
    takes it, right before the work)."""
    output_dir(output)
    study_folder(study).check(output)


def _run_study(study, output: Path, name: str, write: Callable, label: str | None = None) -> tuple:
    """Claim the output folder (right before the work), run the study under a progress bar
    (`label`, default its name) and write its outputs: (results, the paths written)."""
    claim_study_folder(output, name)
    with progress(label or name) as update:
        results = study.run(output, progress=update)
    return results, write(results, output)


def _print_skipped(skipped: dict[str, str]) -> None:
    """The methods a study skipped, each with its reason."""
    for method, reason in skipped.items():
        console.print(f"skipped {shown(method)}: {shown(reason)}", highlight=False)


def _library(library: list[Path] | None):
    from vsmp_imu.smp.library import ActivityLibrary

    return ActivityLibrary.load(library_dirs(library))


@study_app.command("control")
@option_names(CONTROL_OPTIONS)
def control_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="Output folder (report.md, results.json, "
                                "cases.csv, control_results.png; cache/ makes a rerun fast)"),
    seeds: int = typer.Option(5, "--seeds", callback=SEEDS_RANGE,
                              help=f"Generation seeds per level: 0..N-1 (N 1..{SEEDS_MAX})"),
    backend: str = BACKEND_OPTION,
    data_dir: Path | None = typer.Option(None, "--data-dir", help="UTD-MHAD inertial files: ground "
                                         "to them and validate labels with them (default: ground "
                                         "to HAPT)"),
    activities: str | None = typer.Option(None, "--activities", help="Comma-separated UTD-MHAD "
                                          "activities (default: the paper's 12)"),
    controls: str | None = typer.Option(None, "--controls", help="Comma-separated subset of tempo, "
                                        "amplitude, repetitions, duration, symmetry"),
    no_noise: bool = typer.Option(False, "--no-noise", help="Noise-free virtual IMU"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """End-to-end SMP controllability: motion, raw IMU and grounded IMU checkpoints."""
    _output(output, "control")
    from vsmp_imu.studies.control import ATTRIBUTES, ControlStudy
    from vsmp_imu.studies.control_report import write_control_outputs

    _backend(backend)
    study = ControlStudy(
        seeds=range(seeds),
        activities=parse_csv(activities, option="--activities") if activities else None,
        attributes=parse_csv(controls, ATTRIBUTES, "--controls") if controls else None,
        backend=backend, library=_library(library), noise=not no_noise, data_dir=data_dir)
    results, paths = _run_study(study, output, "control", write_control_outputs, "controllability")
    for attribute, s in results.summary.items():
        cp = s["checkpoints"]
        if attribute == "symmetry":
            text = f"accuracy {cp['motion']['accuracy']:.1%}"
        elif attribute == "duration":
            text = ", ".join(f"{k} MAPE {v['mape']:.1%}" for k, v in cp.items())
        else:
            text = ", ".join(f"{k} rho {v['rho_per_set']:.2f}" for k, v in cp.items())
        console.print(f"{attribute}: {shown(text)}", highlight=False)
    console.print(f"wrote {shown(paths['report'])} ({len(results.cases)} motions, {results.elapsed_s:.1f} s)",
                  highlight=False)


@study_app.command("audit")
def audit_cmd(
    pred: Path = typer.Option(..., "--pred", help="Folder of clips: CLIP.raw/ (as `smp extract` "
                              "writes it) or CLIP/ with raw response .txt files; optional clips.csv"),
    ref: Path = typer.Option(..., "--ref", help="Folder of reference SMPs CLIP.json or CLIP.yaml"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    groups: Path | None = typer.Option(None, "--groups", help="CSV clip,group (default: "
                                       "PRED/clips.csv when present)"),
    min_valid: int = typer.Option(3, "--min-valid", callback=int_range(1, 100),
                                  help="Valid responses needed to aggregate (1..100)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """SMP extraction audit: field accuracy, failure accounting, uncertainty calibration."""
    _output(output, "audit")
    from vsmp_imu.studies.audit import ExtractionAudit, load_audit_inputs
    from vsmp_imu.studies.audit_report import write_audit_outputs

    clips = load_audit_inputs(pred, ref, groups)
    claim_study_folder(output, "audit")
    results = ExtractionAudit(_library(library), min_valid).run(clips)
    paths = write_audit_outputs(results, output)
    f = results.failures["overall"]
    refined = results.fields["refined"]
    console.print(f"{f['clips']} clips ({f['evaluated_clips']} aggregated): label accuracy "
                  f"{refined['activity_label']['value']:.1%}, primitive sequence "
                  f"{refined['primitive_sequence']['value']:.1%}, residual error "
                  f"{f['residual_error']:.1%}", highlight=False)
    console.print(f"wrote {shown(paths['report'])}", highlight=False)


@study_app.command("case")
@option_names(CASE_OPTIONS)
def case_cmd(
    activity: str = typer.Option(..., "--activity", help="Library activity"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    video: Path | None = typer.Option(None, "--video", help="Source clip (frames and the pose "
                                      "extractor's SMP; needs the video extra)"),
    seed: int = typer.Option(0, "--seed", callback=SEED_RANGE, help=f"Motion and IMU noise seed {SEED_HELP}"),
    location: str | None = typer.Option(None, "--location", help="Sensor location (default: the "
                                        "activity's dataset location)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Qualitative case study: source frames, SMP, three controlled variants, motions, IMU."""
    _output(output, "case")
    from vsmp_imu.studies.case import CaseStudy, write_case_outputs

    if location is not None:
        from vsmp_imu.imu.placement import get_placement

        location = get_placement(location).name
    activities = _library(library)
    activities.get(activity)  # an unknown activity, before the clip is read
    claim_study_folder(output, "case")
    result = CaseStudy(activity, video=video, seed=seed, library=activities, location=location).run()
    paths = write_case_outputs(result, output)
    for k, var in enumerate(result.variants, start=1):
        console.print(f"variant {k}: {shown(var.variant.title)}", highlight=False)
    console.print(f"wrote {shown(paths['figure'])}", highlight=False)


# -- ablations, granularity, realism -------------------------------------------------------------


def _folds(text: str) -> tuple[str, ...] | None:
    return None if text.strip().lower() == "all" else tuple(parse_csv(text, option="--folds"))


def _protocol(protocol: str, budget: float | None, default: float | None = None) -> float | None:
    """The label budget of a study's protocol: low-resource needs one (`default` when not
    given), the others take none (as `evaluate --budgets`); --budget's range is its callback's."""
    if protocol not in STUDY_PROTOCOLS:
        raise ConfigError(f"the studies do not run protocol '{protocol}'", field="--protocol",
                          allowed=", ".join(STUDY_PROTOCOLS))
    if protocol != "low-resource":
        if budget is not None:
            raise ConfigError("label budgets apply to the low-resource protocol only", field="--budget",
                              allowed="use --protocol low-resource, or leave --budget out")
        return None
    budget = default if budget is None else budget
    if budget is None:
        raise ConfigError("the low-resource protocol needs --budget", field="--budget",
                          allowed=f"a percentage in {MIN_BUDGET:g}..100")
    return budget


def _backbone(name: str, max_epochs: int | None, patience: int | None, jobs: int | None) -> dict:
    from vsmp_imu.har.backbones import BACKBONES, option_params

    parse_csv(name, tuple(BACKBONES), "--backbone")
    return option_params(name, jobs=jobs, max_epochs=max_epochs, patience=patience)


def _backend(name: str) -> None:
    from vsmp_imu.motion.backends import backend_name

    backend_name(name)


def _generation(source: str, k: int, backend: str, workers: int, library: list[Path] | None,
                clips: Path | None = None):
    from vsmp_imu.pipeline.sources import check_source
    from vsmp_imu.pipeline.spec import GenerationSpec

    _backend(backend)
    check_source(source, "--source")
    return GenerationSpec(source=source, k=k, backend=backend, workers=workers,
                          library_dirs=tuple(str(p) for p in library_dirs(library)), clips=str(clips) if clips else None)


@study_app.command("ablation")
@option_names(GENERATION_OPTIONS)
@run_options
def ablation_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="Output folder (report.md, results.json, "
                                "ablation.png, runs/, cache/)"),
    dataset: str = DATASET_OPTION,
    data_dir: Path | None = DATA_DIR_OPTION,
    protocol: str = typer.Option("low-resource", "--protocol", help=PROTOCOL_HELP),
    budget: float | None = typer.Option(None, "--budget", callback=BUDGET_RANGE,
                                        help="Label budget in percent (low-resource only; default 5)"),
    folds: str = FOLDS_OPTION,
    seeds: int = SEEDS_OPTION,
    backbone: str = BACKBONE_OPTION,
    alpha: float = typer.Option(0.5, "--alpha", callback=ALPHA_RANGE, help="Synthetic-to-real ratio of the 2x2 "
                                "and the component ablations (0.1..2.0)"),
    alphas: str = typer.Option("0.1,0.25,0.5,1.0,2.0", "--alphas", callback=finite_list(0.1, 2.0),
                               help="Ratios of the alpha part"),
    parts: str = typer.Option("caption,components,grounding,alpha", "--parts",
                              help="Subset of caption, components, grounding, alpha"),
    source: str = typer.Option("library", "--source", help="Source SMPs: library | smp:DIR | video:DIR"),
    k: int = typer.Option(4, "--k", callback=K_RANGE, help=f"SMP variants (slots) per source SMP, 1..4 (without "
                          f"the caption part 1..{K_MAX})"),
    max_rounds: int = typer.Option(6, "--max-rounds", callback=int_range(1, 100), help="Matched 2x2: generation "
                                   "rounds (first attempt plus replenishments; 1..100)"),
    run: dict | None = None,  # stands for the options of `run_options`
) -> None:
    """Ablations: matched caption-SMP 2x2, components, sensor grounding, alpha sensitivity."""
    _output(output, "ablation")
    from vsmp_imu.studies.ablation import PARTS, AblationStudy
    from vsmp_imu.studies.ablation_report import write_ablation_outputs

    budget = _protocol(protocol, budget, default=5.0)
    alpha_values = tuple(float(a) for a in parse_csv(alphas, option="--alphas"))
    chosen = tuple(parse_csv(parts, PARTS, "--parts"))
    if "caption" in chosen and not 1 <= k <= 4:
        raise ConfigError(f"{k} is out of range", field="--k", allowed="1..4 (the matched 2x2 has four slots)")
    study = AblationStudy(
        dataset=dataset, data_dir=data_dir, protocol=protocol, budget=budget, folds=_folds(folds),
        seeds=seeds, backbone=backbone, alpha=alpha, alphas=alpha_values, max_rounds=max_rounds, parts=chosen,
        options=_generation(source, k, run["backend"], run["workers"], run["library"]),
        backbone_params=_backbone(backbone, run["max_epochs"], run["patience"], run["jobs"]))
    results, paths = _run_study(study, output, "ablation", write_ablation_outputs)
    for name, part in results.parts.items():
        rows = part["rows"].values() if isinstance(part.get("rows"), dict) else part.get("rows", [])
        text = ", ".join(f"{'alpha ' + format(r['alpha'], 'g') if 'alpha' in r else r['method']} "
                         f"{100 * r['macro_f1_mean']:.2f}" for r in rows if r.get("macro_f1_mean") is not None)
        console.print(f"{shown(name)}: {shown(text)}", highlight=False)
    console.print(f"wrote {shown(paths['report'])} ({results.elapsed_s / 60:.1f} min)", highlight=False)


@study_app.command("granularity")
@option_names(GENERATION_OPTIONS)
@run_options
def granularity_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    dataset: str = DATASET_OPTION,
    data_dir: Path | None = DATA_DIR_OPTION,
    taxonomy: Path | None = typer.Option(None, "--taxonomy", help="YAML: group name -> class labels "
                                         "(default: the shipped one of UTD-MHAD or HAPT12)"),
    methods: str = typer.Option("real,imutube,imugpt,vsmp", "--methods", help="Methods to compare"),
    backbone: str = BACKBONE_OPTION,
    protocol: str = typer.Option("lopo", "--protocol", help=PROTOCOL_HELP),
    budget: float | None = typer.Option(None, "--budget", callback=BUDGET_RANGE,
                                        help="Label budget in percent (low-resource only, where it is needed)"),
    folds: str = FOLDS_OPTION,
    seeds: int = SEEDS_OPTION,
    alpha: float = typer.Option(0.5, "--alpha", callback=ALPHA_RANGE, help="Synthetic-to-real ratio (0.1..2.0)"),
    clips: Path | None = typer.Option(None, "--clips", help="Source clips for IMUTube (one folder per "
                                      "activity)"),
    source: str = SOURCE_OPTION,
    k: int = typer.Option(4, "--k", callback=K_RANGE, help=f"SMP variants per source SMP (1..{K_MAX})"),
    describer_url: str | None = DESCRIBER_URL_OPTION,
    describer_model: str | None = DESCRIBER_MODEL_OPTION,
    run: dict | None = None,  # stands for the options of `run_options`
) -> None:
    """Per-class precision/recall/F1 and group Macro-F1 under an activity taxonomy."""
    _output(output, "granularity")
    from vsmp_imu.studies.granularity import GranularityStudy
    from vsmp_imu.studies.granularity_report import write_granularity_outputs
    from vsmp_imu.studies.methods import method_names

    budget = _protocol(protocol, budget)
    chosen = tuple(parse_csv(methods, method_names(), "--methods"))
    study = GranularityStudy(
        dataset=dataset, data_dir=data_dir, taxonomy=taxonomy, methods=chosen, backbone=backbone,
        protocol=protocol, budget=budget, folds=_folds(folds), seeds=seeds, alpha=alpha,
        options=_generation(source, k, run["backend"], run["workers"], run["library"], clips),
        method_options=describer_options(describer_url, describer_model, chosen),
        backbone_params=_backbone(backbone, run["max_epochs"], run["patience"], run["jobs"]))
    results, paths = _run_study(study, output, "granularity", write_granularity_outputs)
    _print_skipped(results.skipped)
    for row in results.groups:
        if row["macro_f1_mean"] is not None:
            console.print(f"{shown(row['method'])} / {shown(row['group'])}: {100 * row['macro_f1_mean']:.2f}", highlight=False)
    console.print(f"wrote {shown(paths['report'])}", highlight=False)


# The realism encoder: 16 times the paper's 64 filters and 128 LSTM units, 4 times its
# mini-batch of 1024 (a few GB of activations at most, each alone, on a CPU)
FILTERS_MAX, HIDDEN_MAX, BATCH_MAX = 1024, 2048, 4096


def _encoder(filters: int, hidden: int, batch_size: int, jobs: int | None) -> dict:
    """The realism encoder's parameters."""
    encoder = {"n_filters": filters, "hidden": hidden, "batch_size": batch_size}
    if jobs:
        encoder["n_threads"] = jobs
    return encoder


@study_app.command("realism")
@option_names(GENERATION_OPTIONS)
def realism_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    dataset: str = DATASET_OPTION,
    data_dir: Path | None = DATA_DIR_OPTION,
    fold: str | None = typer.Option(None, "--fold", help="Held-out subject (default: the first)"),
    methods: str = typer.Option("vsmp,imugpt,classical", "--methods", help="Synthetic methods"),
    seed: int = typer.Option(0, "--seed", callback=SEED_RANGE,
                             help=f"Seed of the split, encoder and generation {SEED_HELP}"),
    alpha: float = typer.Option(0.5, "--alpha", callback=ALPHA_RANGE, help="Synthetic windows per real training window"),
    max_per_class: int = typer.Option(150, "--max-per-class", callback=int_range(1, 100_000),
                                      help="Cap on synthetic windows per class (1..100000)"),
    epochs: int = typer.Option(8, "--epochs", callback=EPOCHS_RANGE,
                               help=f"Encoder epochs at most (CPU: keep modest; 1..{EPOCHS_MAX})"),
    patience: int = typer.Option(3, "--patience", callback=EPOCHS_RANGE,
                                 help=f"Encoder early-stopping patience (1..{EPOCHS_MAX})"),
    # no upper bound: more windows than the data has means all of them
    encoder_windows: int = typer.Option(3000, "--encoder-windows", callback=int_range(0),
                                        help="Real windows the encoder trains on (class-stratified subset; 0 = all)"),
    val_windows: int = typer.Option(1000, "--val-windows", callback=int_range(0), help="Validation windows for "
                                    "early stopping (class-stratified subset; 0 = all)"),
    filters: int = typer.Option(64, "--filters", callback=int_range(1, FILTERS_MAX),
                                help=f"Encoder convolution filters (paper: 64; 1..{FILTERS_MAX})"),
    hidden: int = typer.Option(128, "--hidden", callback=int_range(1, HIDDEN_MAX),
                               help=f"Encoder LSTM units (paper: 128; 1..{HIDDEN_MAX})"),
    batch_size: int = typer.Option(128, "--batch-size", callback=int_range(1, BATCH_MAX),
                                   help=f"Encoder mini-batch (paper: 1024 on a GPU; 1..{BATCH_MAX})"),
    layer: str = typer.Option("conv", "--layer", help="Embedding: conv (final convolutional layer, "
                              "time-averaged; the paper's) | lstm (last LSTM state)"),
    clips: Path | None = typer.Option(None, "--clips", help="Source clips for IMUTube"),
    source: str = SOURCE_OPTION,
    k: int = typer.Option(4, "--k", callback=K_RANGE, help=f"SMP variants per source SMP (1..{K_MAX})"),
    backend: str = BACKEND_OPTION,
    workers: int = WORKERS_OPTION,
    jobs: int | None = typer.Option(None, "--jobs", callback=JOBS_RANGE, help=f"CPU threads of the encoder (1..{JOBS_MAX})"),
    library: list[Path] = LIBRARY_OPTION,
    describer_url: str | None = DESCRIBER_URL_OPTION,
    describer_model: str | None = DESCRIBER_MODEL_OPTION,
) -> None:
    """Feature-space realism: class-wise centroid distances in DeepConvLSTM embeddings, PCA, KS,
    and a two-sample test (RF AUC) on the ECDF features."""
    _output(output, "realism")
    from vsmp_imu.studies.methods import method_names
    from vsmp_imu.studies.realism import LAYERS, RealismStudy
    from vsmp_imu.studies.realism_report import write_realism_outputs

    parse_csv(layer, LAYERS, "--layer")
    encoder = _encoder(filters, hidden, batch_size, jobs)
    chosen = tuple(parse_csv(methods, method_names(), "--methods"))
    study = RealismStudy(
        dataset=dataset, data_dir=data_dir, fold=fold, methods=chosen, seed=seed, alpha=alpha,
        max_per_class=max_per_class, epochs=epochs, patience=patience,
        encoder_windows=encoder_windows or None, val_windows=val_windows or None, layer=layer,
        encoder_params=encoder, options=_generation(source, k, backend, workers, library, clips),
        method_options=describer_options(describer_url, describer_model, chosen))
    results, paths = _run_study(study, output, "realism", write_realism_outputs)
    _print_skipped(results.skipped)
    for row in results.methods:
        d, auc = row["mean_distance"], row["c2st_mean_auc"]
        console.print(f"{shown(row['method'])}: mean centroid distance {'n/a' if d is None else f'{d:.3f}'}, "
                      f"two-sample AUC {'n/a' if auc is None else f'{auc:.2f}'}", highlight=False)
    console.print(f"wrote {shown(paths['report'])}", highlight=False)


def register(app: typer.Typer) -> None:
    """Attach the `study` group to the main app."""
    app.add_typer(study_app, name="study")
