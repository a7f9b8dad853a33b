"""`vsmp-imu evaluate` and `vsmp-imu dataset ...`: the HAR evaluation harness."""

from __future__ import annotations

import json
import re
from collections import Counter
from pathlib import Path
from typing import Any

import typer
from rich.table import Table

from vsmp_imu.cli.common import (
    DESCRIBER_MODEL_OPTION,
    DESCRIBER_URL_OPTION,
    K_UNSEEN,
    LIBRARY_OPTION,
    OVERLAP,
    SPEC_OPTIONS,
    WINDOW_S,
    K,
    console,
    console_err,
    describer_options,
    executor_options,
    grounding_options,
    grounding_spec,
    int_range,
    library_dirs,
    option_names,
    output_dir,
    parse_csv,
    path_text,
    print_warnings,
    probe_folder,
    shown,
)
from vsmp_imu.errors import ConfigError
from vsmp_imu.har.protocols import MAX_RHO, MIN_BUDGET
from vsmp_imu.progress import progress

dataset_app = typer.Typer(help="HAR datasets: list them, inspect one.", no_args_is_help=True)


# the lower bound of the integer options whose upper one is typer's `max` (shown in the help)
POSITIVE = int_range(1)


def _once(items: list[str], option: str) -> tuple[str, ...]:
    """The items of a list option, each named once (a repeat would count a run twice)."""
    twice = [item for item, n in Counter(items).items() if n > 1]
    if twice:
        raise ConfigError(f"{', '.join(twice)} named more than once", field=option, allowed="each value once")
    return tuple(items)


def _parse_folds(text: str) -> tuple[str, ...] | None:
    if text.strip().lower() == "all":
        return None
    return _once(parse_csv(text, option="--folds"), "--folds")


def _parse_budgets(text: str | None) -> tuple[float | None, ...]:
    """`--budgets` as numbers (checked against the protocol later, `EvalConfig.check`)."""
    from vsmp_imu.har.protocols import parse_budgets

    if not text:
        return (None,)
    values = parse_budgets(text, "low-resource")
    _once([f"{float(t.strip().rstrip('%')):g}" for t in text.split(",") if t.strip().rstrip("%")], "--budgets")
    return values


def _parse_seeds(text: str | None) -> tuple[int, ...]:
    if text is None:
        return ()
    items = parse_csv(text, option="--only-seeds")
    bad = [t for t in items if not re.fullmatch(r"[0-9]{1,6}", t)]
    if bad:
        raise ConfigError(f"{', '.join(bad)}: not a seed", field="--only-seeds",
                          allowed="seeds 0..N-1 of --seeds N, e.g. 1,2")
    return tuple(dict.fromkeys(int(t) for t in items))


def _parse_groups(items: list[str] | None) -> dict[str, tuple[str, ...]]:
    groups: dict[str, tuple[str, ...]] = {}
    for item in items or []:
        for part in item.split(";"):
            if not part.strip():
                continue
            if "=" not in part:
                raise ConfigError(
                    f"'{part}' is not NAME=CLASS,CLASS",
                    field="--report-groups",
                    allowed="e.g. transitions=STAND_TO_SIT,SIT_TO_STAND",
                )
            name, members = part.split("=", 1)
            groups[name.strip()] = tuple(parse_csv(members, option="--report-groups"))
    return groups


def budget_defaults(protocol: str, alpha: float | None, policy: str | None) -> tuple[float, str]:
    """The synthetic budget's alpha and policy where not given: tstr trains on as many synthetic
    windows per class as the real training set has (alpha 1, uniform), so that it reads against
    TRTR; unseen gives synthetic windows to the unseen classes only (tail: seen-class synthetic
    windows cost the unseen ones, docs/results.md, "The seen classes' map is not lent to an unseen
    class"); the other protocols take GenerationSpec's (alpha 2, scarcity: "Defaults")."""
    from vsmp_imu.pipeline.spec import GenerationSpec

    tstr, spec = protocol == "tstr", GenerationSpec()
    default_policy = {"tstr": "uniform", "unseen": "tail"}.get(protocol, spec.policy)
    return (alpha if alpha is not None else 1.0 if tstr else spec.alpha,
            policy if policy is not None else default_policy)


@option_names(SPEC_OPTIONS)
@grounding_options
def evaluate_cmd(
    dataset: str = typer.Option(
        ...,
        "--dataset",
        "-d",
        help="hapt, hapt12, mmfit, utd-mhad, mmact, pamap2, had-aw, or a dataset .yaml file",
    ),
    protocol: str = typer.Option(
        "lopo", "--protocol", "-p", help="lopo | low-resource | long-tail | unseen | tstr (train on synthetic only)"
    ),
    unseen: str = typer.Option(
        None, "--unseen",
        help="unseen protocol: classes or groups with no real training window (CLASS,CLASS or a "
             "group such as transitions), or 'each' for leave-one-class-out",
    ),
    budgets: str = typer.Option(
        None, "--budgets", help=f"label budgets in percent, {MIN_BUDGET:g}..100, for low-resource (default "
                                "1,5,10,25,50) and tstr (default: every window grounds the synthetic ones); a "
                                f"class keeps at least 1 window, so a smaller budget would only repeat {MIN_BUDGET:g}'s"
    ),
    backbones: str = typer.Option("rf", "--backbones", help="rf,rf-seg,dclstm,dclstm-attn,bilstm-attn"),
    methods: str = typer.Option(
        "real", "--methods", help="real,classical (and registered sources)"
    ),
    folds: str = typer.Option("all", "--folds", help="'all' or held-out subjects, e.g. 1,2,3"),
    seeds: int = typer.Option(1, "--seeds", max=1000, help="number of seeds (0..N-1)"),
    only_seeds: str = typer.Option(
        None, "--only-seeds",
        help="run only these of the --seeds (e.g. 1,2), to spread one evaluation over processes; "
             "their records are those --seeds N writes"),
    alpha: float = typer.Option(
        None, "--alpha", show_default=False,
        help="synthetic-to-real ratio, 0.1..2.0 (the paper: 0.5) [default: 1 for tstr, else 2]"),
    policy: str = typer.Option(
        None, "--policy", show_default=False,
        help="synthetic budget per class: uniform | tail | scarcity (the paper: uniform) "
             "[default: uniform for tstr, tail for unseen, else scarcity]"),
    rho: float = typer.Option(
        10.0, "--rho", help=f"long-tail: head-to-tail imbalance ratio, above 1 and at most {MAX_RHO:g} (a class "
                            "keeps at least 1 window, so a ratio above the largest class's windows is not delivered)"),
    window_s: float = WINDOW_S,
    overlap: float = OVERLAP,
    data_dir: Path = typer.Option(None, "--data-dir", help="folder of a downloaded dataset"),
    max_epochs: int = typer.Option(None, "--max-epochs", max=100000, callback=POSITIVE,
                                   help="neural backbones: epoch limit"),
    patience: int = typer.Option(
        None, "--patience", max=100000, callback=POSITIVE, help="neural backbones: early-stopping patience"
    ),
    jobs: int = typer.Option(None, "--jobs", max=256, callback=POSITIVE, help="CPU threads for RF and PyTorch"),
    device: str = typer.Option(None, "--device", show_default=False,
                               help="neural backbones: cpu | cuda | cuda:N | mps | auto [default: cpu]"),
    class_weight: str = typer.Option(
        None, "--class-weight", show_default=False,
        help="balanced (each class weighted by the inverse of its training windows, in a forest's "
             "splits and a network's loss, so a class with few windows counts as much as the "
             "others) | none (the paper's unweighted training) [default: balanced where every "
             "chosen backbone takes class and window weights, else none]"),
    synthetic_weight: str = typer.Option(
        None, "--synthetic-weight", show_default=False,
        help="with balanced classes: the classes weigh alike per source, and a class's synthetic "
             "windows together weigh this share of its real ones, however many there are (a "
             "class without real windows keeps a full class's weight); off: every window of a "
             "class weighs alike [default: 0.5 with balanced classes, else off]"),
    report_groups: list[str] = typer.Option(
        None, "--report-groups", help="NAME=CLASS,CLASS;... classes reported together"
    ),
    source: str = typer.Option(
        "library", "--source", help="generative methods: library | smp:DIR | video:DIR"
    ),
    k: int = K,
    k_unseen: int = K_UNSEEN,
    backend: str = typer.Option("procedural", "--backend", help="motion backend: procedural | compiled | hymotion"),
    grounding: dict | None = None,  # stands for the grounding options (`grounding_options`)
    workers: int = typer.Option(1, "--workers", max=256, callback=POSITIVE, help="generation workers"),
    executor: str = typer.Option("local", "--executor", help="generation executor: local | ray"),
    address: str = typer.Option(None, "--address", help="Ray cluster address (--executor ray)"),
    library: list[Path] = LIBRARY_OPTION,
    refill: int = typer.Option(0, "--refill", min=0, max=8,
                               help="VSMP-IMU: extra passes for classes short of their budget after filtering"),
    cache_dir: Path = typer.Option(None, "--cache-dir", parser=path_text, metavar="DIR",
                                   help="generated-sample cache (default: the cache directory, see `vsmp-imu cache "
                                        "info`); its samples are kept below the same size cap"),
    describer_url: str = DESCRIBER_URL_OPTION,
    describer_model: str = DESCRIBER_MODEL_OPTION,
    share_selection: str = typer.Option(
        None, "--share-selection", show_default=False,
        help="do no harm: drop a method's synthetic windows where they measurably lower the validation "
             "subjects' true-class probability: method (all together) | class (per class, judged where "
             "the validation subjects hold 10 windows of it) | amount (the share of them, 0 to 1, the "
             "validation subjects score best) | off [default: class under lopo, long-tail and unseen "
             "where every chosen backbone is a forest, else off]"),
    processes: int = typer.Option(
        1, "--processes", min=1, max=64,
        help="run the folds in this many evaluate processes side by side, one fold each (each with "
             "--jobs threads and --workers generation workers); their records merge into the output folder"),
    output: Path = typer.Option(..., "--output", "-o", parser=path_text, metavar="DIR",
                                help="output folder: a new or empty one, or one of an earlier evaluate with the "
                                     "same settings (resumed, or extended by more methods, folds or seeds)"),
) -> None:
    """Evaluate backbones x methods under a LOPO protocol; writes results.json, results.md and
    confusion matrices to the output folder (finished folds are not recomputed)."""
    _check_folders(output, cache_dir)
    executor_options(executor, address)
    from vsmp_imu.app import EvalRequest, evaluate, evaluation
    from vsmp_imu.har.backbones import BACKBONES
    from vsmp_imu.har.output import claim
    from vsmp_imu.motion.backends import check_backend
    from vsmp_imu.pipeline.sources import check_source
    from vsmp_imu.pipeline.spec import GenerationSpec

    check_backend(backend, "--backend")  # before the dataset loads, even where no method animates
    check_source(source, "--source")  # likewise, even where no method reads SMPs
    chosen_backbones = _once(parse_csv(backbones, tuple(BACKBONES), "--backbones"), "--backbones")
    chosen_methods = _once(parse_csv(methods, option="--methods"), "--methods")
    describer = describer_options(describer_url, describer_model, chosen_methods)
    share_selection = share_default(protocol, chosen_backbones, share_selection)
    alpha, policy = budget_defaults(protocol, alpha, policy)
    class_weight, share = weighting(chosen_backbones, class_weight, synthetic_weight)
    request = EvalRequest(
        dataset=dataset, output=output, protocol=protocol,
        budgets=_parse_budgets(budgets),
        backbones=chosen_backbones, methods=chosen_methods, method_options=describer,
        folds=_parse_folds(folds), seeds=seeds, only_seeds=_parse_seeds(only_seeds), rho=rho, window_s=window_s, overlap=overlap,
        data_dir=data_dir, backbone_params=_backbone_params(chosen_backbones, max_epochs, patience, jobs, device,
                                                             class_weight),
        report_groups=_parse_groups(report_groups), share_selection=share_selection,
        synthetic_weight=share,
        unseen=_once(parse_csv(unseen, option="--unseen"), "--unseen") if unseen is not None else ())
    spec = GenerationSpec(
        source=source, alpha=alpha, policy=policy, k=k, k_unseen=k_unseen, backend=backend,
        **grounding_spec(grounding), library_dirs=tuple(str(p) for p in library_dirs(library)), refill=refill,
        executor=executor, workers=workers, address=address, cache_dir=str(cache_dir) if cache_dir else None)
    run = evaluation(spec, request)
    _, folds = run.windows_and_folds()  # checked before the folder is claimed
    claim(run)  # refuses a folder whose records were made with other settings or data
    print_warnings(run.dataset.warnings)
    if processes > 1:
        _fold_processes(run, spec, request, processes, folds)
    with progress(f"{run.dataset.info.name} {protocol}", console=console, transient=False) as update:
        results, written = evaluate(run, lambda stage, done, total: update(done, total, stage))
    _print_summary(results.summary)
    _print_paired(results.to_json())
    console.print(
        f"[green]wrote[/] {shown(output / 'results.json')}, {shown(written[0])} and "
        f"{len(written) - 1} confusion matrices"
    )


def _check_folders(output: Path, cache_dir: Path | None) -> None:
    """Before any work: the output folder is new, empty or an earlier evaluate's, and both
    folders can be written (a probe file)."""
    from vsmp_imu.har.output import check_folder

    output_dir(output)
    check_folder(output)
    probe_folder(output)
    if cache_dir is not None:
        output_dir(cache_dir, "--cache-dir")
        probe_folder(cache_dir, "--cache-dir")


def _fold_processes(run, spec, request, processes: int, folds: list[str]) -> None:
    """`--processes N`: every fold in its own process first (`vsmp_imu.har.fanout`); the
    evaluation that follows finds their records done. A failed fold stops the command (exit 1)."""
    from vsmp_imu.har.fanout import run_folds

    console.print(f"{len(folds)} fold(s) in {min(processes, len(folds))} processes; each fold's progress "
                  f"in {shown(request.output / '.folds')}/fold-FOLD/log.txt", highlight=False)

    def tell(outcome, finished: int, total: int) -> None:
        state = f"{outcome.records} record(s)" if outcome.ok else f"[red]failed[/] (exit {outcome.exit_code})"
        console.print(f"fold {shown(outcome.fold)}: {state} {finished}/{total}", highlight=False)

    failed = [o for o in run_folds(spec, request, folds, processes, tell) if not o.ok]
    if failed:
        for o in failed:
            console_err.print(f"fold {shown(o.fold)} failed: {shown(o.last_line())} (whole log: {shown(o.log)})",
                              highlight=False, soft_wrap=True)
        console_err.print("the other folds' records are kept: run the same command again to redo the failed ones",
                          highlight=False)
        raise typer.Exit(1)


CLASS_WEIGHTS = ("none", "balanced")
GUARDED_PROTOCOLS = ("lopo", "long-tail", "unseen")  # the per-class guard by default (`share_default`)


def share_default(protocol: str, chosen: tuple[str, ...], share_selection: str | None) -> str:
    """`--share-selection` as given, or its default: the per-class guard where the training
    subjects keep all their labels (lopo, long-tail, unseen) and every chosen backbone is a
    forest (two extra fits of a forest per run; on HAPT12's long tail it took the tail from
    significantly below Real-only to level, docs/results.md "The guard judges a class on its own
    windows"); off under low-resource (a no-op at 1 %, level at 5 %, at the price of the extra
    fits: BENCHMARKS.md), under tstr (no real-only model to weigh against) and where a network
    is chosen (two extra trainings, not measured)."""
    from vsmp_imu.har.backbones import BACKBONES
    from vsmp_imu.har.noharm import check_mode

    if share_selection is not None:
        return check_mode(share_selection)
    forests = all(not getattr(BACKBONES[b], "uses_validation", True) for b in chosen)
    return "class" if forests and protocol in GUARDED_PROTOCOLS else "off"


def weighting(chosen: tuple[str, ...], class_weight: str | None,
              synthetic_weight: str | None) -> tuple[str, float | None]:
    """`--class-weight` and `--synthetic-weight` as given, or their defaults: balanced classes
    with a class's synthetic windows at half its real ones (`DEFAULT_SYNTHETIC_WEIGHT`), where
    every chosen backbone takes class weights and per-window weights; else the paper's
    unweighted training, said on the console. A share given with `none` is refused later
    (`EvalConfig.check`)."""
    from vsmp_imu.har.backbones import BACKBONES
    from vsmp_imu.har.weights import (
        DEFAULT_CLASS_WEIGHT,
        DEFAULT_SYNTHETIC_WEIGHT,
        parse_synthetic_weight,
        takes_sample_weight,
    )

    if class_weight is None:
        no_class_weight = _without_class_weight(chosen)
        unable = [b for b in chosen if b in no_class_weight or not takes_sample_weight(BACKBONES[b])]
        class_weight = "none" if unable else DEFAULT_CLASS_WEIGHT
        if unable:
            console.print(f"[yellow]note:[/] {', '.join(unable)} take(s) no class or window weights: "
                          "every backbone trains unweighted (--class-weight none)")
    if synthetic_weight is not None:
        return class_weight, parse_synthetic_weight(synthetic_weight)
    return class_weight, DEFAULT_SYNTHETIC_WEIGHT if class_weight == "balanced" else None


def _without_class_weight(chosen: tuple[str, ...]) -> list[str]:
    """The chosen backbones that have no `class_weight` parameter."""
    from vsmp_imu.har.backbones import make_backbone

    return [b for b in chosen if "class_weight" not in make_backbone(b).get_params()]


DEVICE_NAME = re.compile(r"cpu|cuda|cuda:[0-9]+|mps|auto")  # `resolve_device`'s names


def _check_device(device: str | None, used: bool) -> None:
    """`--device` where given: resolved where a chosen backbone takes it (an unknown or absent
    device fails before any data is loaded); else its name checked, and said to be unused."""
    from vsmp_imu.har.backbones.neural import DEVICES, resolve_device

    if device is None:
        return
    if used:
        resolve_device(device)
    elif not DEVICE_NAME.fullmatch(device.strip().lower()):
        raise ConfigError(f"unknown device '{device}'", field="--device", allowed=", ".join(DEVICES))
    else:
        console.print("[yellow]note:[/] --device is unused: no chosen backbone is a network", highlight=False)


def _backbone_params(chosen: tuple[str, ...], max_epochs: int | None, patience: int | None,
                     jobs: int | None, device: str | None, class_weight: str = "none") -> dict[str, dict[str, Any]]:
    """Per backbone: the options given that it takes (`option_params`). A class weight that a
    chosen backbone cannot take is refused, so every backbone of a run is weighted alike."""
    from vsmp_imu.har.backbones import make_backbone, option_params

    accepted = {b: make_backbone(b).get_params() for b in chosen}
    _check_device(device, any("device" in a for a in accepted.values()))
    if class_weight not in CLASS_WEIGHTS:  # one value: a list would reach the forest unparsed
        raise ConfigError(f"unknown class weight '{class_weight}'", field="--class-weight",
                          allowed=", ".join(CLASS_WEIGHTS))
    weighted = class_weight != "none"
    unweighted = _without_class_weight(chosen)
    if weighted and unweighted:
        raise ConfigError(f"backbone(s) {', '.join(unweighted)} take no class weights", field="--class-weight",
                          allowed="none, or only backbones that take a class_weight parameter")
    params = {b: option_params(b, jobs=jobs, max_epochs=max_epochs, patience=patience,
                               device=None if device in (None, "cpu") else device,
                               class_weight=class_weight if weighted else None) for b in chosen}
    return {b: p for b, p in params.items() if p}


def _pct(mean: float | None, std: float | None) -> str:
    return "–" if mean is None else f"{100 * mean:.2f} ± {100 * (std or 0):.2f}"


SHORTFALL_NOTE = 0.95  # a method that delivers less than this share of its budget is named


def _shortfalls(summary: list[dict[str, Any]]) -> list[str]:
    """One line per row whose method mixed in clearly fewer synthetic windows than asked for."""
    lines = []
    for row in summary:
        asked = row.get("n_synthetic_requested_mean")
        if asked and row["n_synthetic_mean"] < SHORTFALL_NOTE * asked:
            budget = "" if row["budget"] is None else f" {row['budget']:g}%"
            lines.append(f"{row['method']} ({row['protocol']}{budget}, {row['backbone']}) mixed in "
                         f"{row['n_synthetic_mean']:.0f} of the {asked:.0f} synthetic windows asked for "
                         f"per run ({100 * row['n_synthetic_mean'] / asked:.0f} %)")
    return lines


def _unseen_title(row: dict[str, Any]) -> str:
    names = row["unseen_classes"]
    return shown(names[0] if len(names) == 1 else f"{len(names)} classes ({', '.join(names)})")


def _print_unseen(summary: list[dict[str, Any]]) -> None:
    """The unseen protocol's tables, one per unseen set: unseen- and seen-class Macro-F1 and the
    confusion between the two sides; a method that cannot make an unseen class is starred (the
    floor)."""
    sets: dict[tuple[str, ...], list[dict[str, Any]]] = {}
    for row in summary:
        sets.setdefault(tuple(row["unseen_classes"]), []).append(row)
    for rows in sets.values():
        table = Table(title=f"Unseen: {_unseen_title(rows[0])}; % over folds and seeds")
        for col in ("method", "unseen F1", "seen F1", "seen→uns.", "uns.→seen", "n"):
            table.add_column(col)
        for row in rows:
            star = "" if row["unseen_capable"] else "*"
            table.add_row(
                f"{row['method']}{star}/{row['backbone']}",
                _pct(row["unseen_macro_f1_mean"], row["unseen_macro_f1_std"]),
                _pct(row["seen_macro_f1_mean"], row["seen_macro_f1_std"]),
                _share(row["seen_as_unseen_mean"]), _share(row["unseen_as_seen_mean"]), str(row["n"]),
            )
        console.print(table)
    if len(sets) > 1:  # leave-one-class-out: the mean over the unseen sets
        for (method, backbone), f1 in _mean_unseen_f1(summary).items():
            console.print(f"{method}/{backbone}: mean unseen-class Macro-F1 over the {len(sets)} unseen "
                          f"sets {_share(f1)} %", highlight=False)
    console.print("seen→uns.: share of seen-class test windows predicted as an unseen class; "
                  "uns.→seen: the reverse; * cannot make windows of a class without real windows "
                  "(the floor).", highlight=False)
    for line in _shortfalls(summary):
        console.print(f"[yellow]note:[/] {shown(line)}", highlight=False)


def _mean_unseen_f1(summary: list[dict[str, Any]]) -> dict[tuple[str, str], float | None]:
    """Per (method, backbone): the mean over the unseen sets of their unseen-class Macro-F1."""
    values: dict[tuple[str, str], list[float]] = {}
    for row in summary:
        f1 = row["unseen_macro_f1_mean"]
        values.setdefault((row["method"], row["backbone"]), []).extend([] if f1 is None else [f1])
    return {key: (sum(v) / len(v) if v else None) for key, v in values.items()}


def _share(value: float | None) -> str:
    return "–" if value is None else f"{100 * value:.1f}"


def _print_summary(summary: list[dict[str, Any]]) -> None:
    if summary and all(row.get("unseen_classes") for row in summary):
        _print_unseen(summary)
        return
    table = Table(title="Macro-F1 (%) over folds and seeds")
    for col in ("protocol", "budget", "backbone", "method", "Macro-F1", "Accuracy", "n"):
        table.add_column(col)
    for row in summary:
        table.add_row(
            row["protocol"],
            "" if row["budget"] is None else f"{row['budget']:g}%",
            row["backbone"],
            row["method"],
            _pct(row["macro_f1_mean"], row["macro_f1_std"]),
            _pct(row["accuracy_mean"], row["accuracy_std"]),
            str(row["n"]),
        )
    console.print(table)
    for line in _shortfalls(summary) + _share_notes(summary):
        console.print(f"[yellow]note:[/] {shown(line)}", highlight=False)


def _print_paired(results: dict[str, Any]) -> None:
    """Each method against Real-only (and Classical Aug) over the same runs, on Macro-F1 and the
    protocol's own figure (tail, unseen classes): `results.md` has every group too."""
    from vsmp_imu.har.report import paired_rows

    metrics, rows = paired_rows(results["records"], results.get("config", {}))
    shown = [i for i, m in enumerate(metrics) if not m.metric.startswith("group:")]
    if not rows or not any(r.get("n", 0) > 1 for r in results["summary"]):
        return  # one run per method: nothing to test
    table = Table(title="Paired over the same folds and seeds: difference (runs won, Wilcoxon p)")
    for col in ("backbone", "budget", "pair", *(metrics[i].label for i in shown)):
        table.add_column(col)
    for row in rows:
        table.add_row(*row[:3], *(row[3 + i] for i in shown))
    console.print(table)


def _share_notes(summary: list[dict[str, Any]]) -> list[str]:
    """One line per row where the share selection mixed no synthetic window of some class."""
    lines = []
    for row in summary:
        shares = row.get("synthetic_shares") or {}
        parts = [f"{name} in {s['none']}/{s['runs']} runs" for name, s in shares.items() if s["none"]]
        unjudged = [f"{name} ({s['unjudged']}/{s['runs']})" for name, s in shares.items() if s["unjudged"]]
        budget = "" if row["budget"] is None else f" {row['budget']:g}%"
        where = f"{row['method']} ({row['protocol']}{budget}, {row['backbone']})"
        if parts:
            lines.append(f"{where}: no synthetic windows mixed (measured harm on the validation subjects) "
                         f"for {', '.join(parts)}")
        if unjudged:
            lines.append(f"{where}: kept unjudged by the guard (too few validation windows): {', '.join(unjudged)}")
    return lines


@dataset_app.command("list")
def list_cmd() -> None:
    """The registered dataset names."""
    from vsmp_imu.har.datasets import DATASETS

    table = Table(title="HAR datasets")
    table.add_column("name")
    table.add_column("needs --data-dir")
    table.add_column("description")
    for name, (_, needs_dir, description) in DATASETS.items():
        table.add_row(name, "yes" if needs_dir else "no", description)
    table.add_row("path/to/dataset.yaml", "no", "your own data in the generic format")
    console.print(table)


@dataset_app.command("info")
def info_cmd(
    name: str = typer.Argument(..., help="dataset name or dataset .yaml file"),
    data_dir: Path = typer.Option(None, "--data-dir", help="folder of a downloaded dataset"),
    window_s: float = WINDOW_S,
    overlap: float = OVERLAP,
    measure: str = typer.Option(
        None, "--measure", help="a static class: print its mean acceleration per channel"
    ),
    as_json: bool = typer.Option(False, "--json", help="print JSON"),
) -> None:
    """Subjects, classes with window counts, channels, rate and declared conventions."""
    from vsmp_imu.har.dataset import measure_static_gravity
    from vsmp_imu.har.datasets import load_dataset

    ds = load_dataset(name, data_dir)
    print_warnings(ds.warnings)
    info = ds.describe(window_s, overlap)
    if measure:
        windows = ds.windows(window_s, overlap)
        with option_names({"label": "--measure"}):  # a class the dataset does not have
            measured = measure_static_gravity(windows, measure)
        info["measured_mean_acc"] = {"class": measure, **measured}
    if as_json:
        typer.echo(json.dumps(info, indent=2))
        return
    console.print(f"[bold]{shown(info['name'])}[/] — {shown(info['description'])}")
    console.print(f"source: {shown(info['source'])}")
    console.print(
        f"rate {info['fs_hz']:g} Hz, {len(info['subjects'])} subjects "
        f"({shown(', '.join(info['subjects']))}), {info['n_recordings']} recordings"
    )
    console.print(f"channels: {shown(', '.join(info['channel_names']))}")
    for loc in info["locations"]:
        axes = ", ".join(loc["axes"]) if loc["axes"] else "not declared"
        console.print(
            f"  [bold]{shown(loc['name'])}[/]: axes (x, y, z) = {shown(axes)} "
            f"{shown('[' + loc['axes_source'] + ']')}, "
            f"gravity {'included' if loc['gravity_included'] else 'removed'}, "
            f"source units {shown(loc['acc_unit'])}, {shown(loc['gyr_unit'] or 'no gyroscope')}"
            + (f" — {shown(loc['note'])}" if loc["note"] else "")
        )
    table = Table(title=f"{info['n_windows']} windows of {window_s:g} s, overlap {overlap:g}")
    table.add_column("class")
    table.add_column("windows", justify="right")
    for label, count in info["windows_per_class"].items():
        table.add_row(shown(label), str(count))
    console.print(table)
    for group, members in info["groups"].items():
        console.print(f"group {shown(group)}: {shown(', '.join(members))}")
    if info.get("measured_mean_acc"):
        m = info["measured_mean_acc"]
        values = ", ".join(f"{k} {v:+.2f}" for k, v in m.items() if k != "class")
        console.print(f"mean acceleration of '{shown(m['class'])}' windows (m/s²): {shown(values)}")
    for line in info["skipped"]:
        console.print(f"[yellow]skipped[/] {shown(line)}")


def register(app: typer.Typer) -> None:
    """Attach `evaluate` and the `dataset` group to the main app."""
    app.command("evaluate")(evaluate_cmd)
    app.add_typer(dataset_app, name="dataset")
