"""`vsmp-imu evaluate` and `vsmp-imu dataset ...` on the command line."""

from __future__ import annotations

import json
import re

import pytest

from vsmp_imu.errors import ConfigError


def test_dataset_list(cli):
    code, out, _ = cli("dataset", "list")
    assert code == 0
    for name in ("hapt", "hapt12", "mmfit", "utd-mhad", "mmact", "pamap2", "had-aw"):
        assert name in out


def test_dataset_info_hapt(cli):
    code, out, _ = cli("dataset", "info", "hapt", "--measure", "STANDING")
    assert code == 0
    assert "30 subjects" in out and "61 recordings" in out
    assert "up, forward, left" in out and "[measured]" in out
    assert "STANDING" in out and "2519" in out  # windows of standing
    assert "acc_x +9.82" in out


def test_dataset_info_json_for_fixture(cli, fixtures_dir):
    code, out, _ = cli("dataset", "info", "pamap2", "--data-dir", fixtures_dir / "pamap2", "--json")
    assert code == 0
    info = json.loads(out)
    assert info["subjects"] == ["101", "102"] and info["fs_hz"] == 100.0
    assert info["windows_per_class"]["walking"] == 2
    assert info["locations"][1]["name"] == "chest" and info["locations"][1]["axes"] is None


@pytest.mark.parametrize(
    "args,option,allowed",
    [
        (("--alpha", "5"), "--alpha", "0.1 <= alpha <= 2"),
        (("--protocol", "low-resource", "--budgets", "0,5"), "--budgets", "[0.01, 100]"),
        (("--protocol", "low-resource", "--budgets", "150"), "--budgets", "[0.01, 100]"),
        (("--protocol", "low-resource", "--budgets", "1e-9"), "--budgets", "[0.01, 100]"),  # 1 window a class
        (("--protocol", "tstr", "--budgets", "0.001"), "--budgets", "[0.01, 100]"),
        (("--budgets", "5"), "--budgets", "low-resource"),
        (("--folds", "1,99"), "--folds", "subjects 1, 2, 3"),
        (("--seeds", "0"), "--seeds", ">= 1"),
        (("--protocol", "kfold"), "--protocol", "lopo, low-resource, long-tail"),
        (("--backbones", "rf,svm"), "--backbones", "rf, rf-seg, dclstm, dclstm-attn, bilstm-attn"),
        (("--methods", "real,magic"), "--methods", "real, classical"),
        (("--overlap", "1.5"), "--overlap", "0..0.9, not 1.5"),
        (("--overlap", "nan"), "--overlap", "0..0.9, not nan"),
        (("--overlap", "0.95"), "--overlap", "0..0.9, not 0.95"),  # a hop of 5 % of a window: 10x the windows
        (("--workers", "0"), "--workers", ">= 1"),
        (("--max-epochs", "0"), "--max-epochs", ">= 1"),
        (("--policy", "greedy"), "--policy", "uniform, tail, scarcity"),
        (("--protocol", "long-tail", "--rho", "1"), "--rho", "1 < rho <= 1000"),
        (("--protocol", "long-tail", "--rho", "1e12"), "--rho", "1 < rho <= 1000"),  # the tails at 1 window
        (("--protocol", "long-tail", "--rho", "inf"), "--rho", "1 < rho <= 1000"),
        (("--backbones", "dclstm", "--device", "tpu9"), "--device", "cpu, cuda, cuda:N, mps, auto"),
        (("--class-weight", "equal"), "--class-weight", "none, balanced"),
        (("--class-weight", "none,balanced"), "--class-weight", "none, balanced"),
        (("--unseen-intensity", "2,1"), "--unseen-intensity", "0 < LO <= HI"),
        (("--unseen-intensity", "on"), "--unseen-intensity", "0 < LO <= HI"),
    ],
)
def test_out_of_range_options_exit_2(cli, tmp_path, args, option, allowed):
    code, _, err = cli("evaluate", "--dataset", "hapt", *args, "-o", tmp_path / "out")
    assert code == 2
    assert option in err and allowed in err
    assert not (tmp_path / "out" / "results.json").exists()


@pytest.mark.parametrize("value", ["0.999", "0.95", "-1", "nan", "inf"])
@pytest.mark.parametrize("command", ["evaluate", "dataset info", "generate"])
def test_overlap_is_bounded_alike_in_every_windowing_command(cli, tmp_path, command, value):
    """A hop of a thousandth of a window made a thousand times the windows (GBs in a minute): the
    commands take 0..0.9 and say so in the same words, before the dataset loads (generate took 0.95)."""
    args = {"evaluate": ("evaluate", "--dataset", "hapt", "-o", tmp_path / "out"),
            "dataset info": ("dataset", "info", "hapt"),
            "generate": ("generate", "--dataset", "hapt", "--holdout", "1", "-o", tmp_path / "out")}[command]
    code, _, err = cli(*args, "--overlap", value)
    text = " ".join(err.replace("│", " ").split())
    assert code == 2 and f"Invalid value for '--overlap': must be a finite number in 0..0.9, not {value}" in text


def test_dataset_info_takes_the_largest_overlap_evaluate_takes(cli):
    code, out, _ = cli("dataset", "info", "hapt", "--overlap", "0.9", "--json")
    assert code == 0 and json.loads(out)["overlap"] == 0.9


def test_dataset_info_measure_of_an_unknown_class_names_the_option(cli):
    code, _, err = cli("dataset", "info", "hapt", "--measure", "FLYING")
    assert code == 2 and err.startswith("field '--measure': unknown class 'FLYING'. Allowed: WALKING,")


@pytest.mark.parametrize(("args", "says"), [
    (("--backend", "mocap"), "field '--backend': unknown motion backend 'mocap'. "
                             "Allowed: procedural, compiled, hymotion."),
    (("--source", "youtube"), "field '--source': unknown source 'youtube'. Allowed: library, smp:DIR, video:DIR."),
    (("--source", "smp:"), "field '--source': source 'smp' needs a folder: smp:DIR."),
    (("--source", "smp:MISSING"), "MISSING: field '--source': SMP source folder not found. "
                                  "Allowed: library, smp:DIR, video:DIR (an existing folder)."),
    (("--source", "video:MISSING"), "MISSING: field '--source': video source folder not found."),
    (("--library", "MISSING"), "MISSING: field '--library': not found. Allowed: a folder of activity files"),
])
def test_backend_and_source_are_named_and_refused_before_the_dataset_loads(cli, tmp_path, args, says):
    """Named by the option typed, even where no method animates or reads SMPs (--methods real):
    the missing dataset file would be the error if the dataset loaded first."""
    missing = str(tmp_path / "nowhere")
    args = tuple(a.replace("MISSING", missing) for a in args)
    code, _, err = cli("evaluate", "--dataset", tmp_path / "missing.yaml", "--methods", "real", *args,
                       "-o", tmp_path / "out")
    assert code == 2 and says.replace("MISSING", missing) in err, err
    assert "missing.yaml" not in err and not (tmp_path / "out" / "results.json").exists()


def test_a_cuda_device_without_cuda_exits_2(cli, tmp_path):
    torch = pytest.importorskip("torch")
    if torch.cuda.is_available():
        pytest.skip("a CUDA device is present here")
    code, _, err = cli("evaluate", "--dataset", "hapt", "--backbones", "dclstm", "--device", "cuda",
                       "-o", tmp_path / "out")
    assert code == 2 and "--device" in err and "0 CUDA device" in err


def test_unknown_dataset_and_missing_data_dir_exit_2(cli, tmp_path):
    code, _, err = cli("evaluate", "--dataset", "kinetics", "-o", tmp_path)
    assert code == 2 and "hapt12" in err
    code, _, err = cli("dataset", "info", "pamap2")
    assert code == 2 and "--data-dir" in err


def test_long_tail_with_classical_on_generic_data(cli, fixtures_dir, tmp_path):
    out = tmp_path / "lt"
    code, stdout, _ = cli(
        "evaluate",
        "--dataset",
        fixtures_dir / "generic" / "dataset.yaml",
        "--protocol",
        "long-tail",
        "--methods",
        "real,classical",
        "--policy",
        "tail",
        "--rho",
        "2",
        "--alpha",
        "1.0",
        "--backbones",
        "rf",
        "--jobs",
        "1",
        "-o",
        out,
    )
    assert code == 0, stdout
    results = json.loads((out / "results.json").read_text())
    assert {r["method"] for r in results["records"]} == {"real", "classical"}
    for r in results["records"]:
        assert r["head_classes"] == ["walk"] and r["tail_classes"] == ["sit"]
        assert r["head_macro_f1"] is not None and r["tail_macro_f1"] is not None
        if r["method"] == "real":
            assert r["n_synthetic"] == 0
    classical = [r for r in results["records"] if r["method"] == "classical"]
    assert all(r["n_synthetic"] > 0 for r in classical)
    md = (out / "results.md").read_text()
    assert "Head Macro-F1" in md and "Classical Aug." in md
    delivered = md.split("Synthetic windows mixed in")[1]
    assert "| Classical Aug. |" in delivered and "| 100 % |" in delivered
    assert "synthetic windows asked for" not in stdout  # Classical Aug delivers its whole budget
    # the per-class guard (the default with a forest) says what it could not judge
    assert "kept unjudged by the guard (too few validation windows): sit (3/3)" in " ".join(stdout.split())
    # the paired differences, in results.md and on the console (Macro-F1 and the tail)
    assert "| RF |  | Classical Aug. vs. Real-only |" in md
    console = stdout[stdout.index("Paired over the same folds and seeds"):]  # cells wrap at 80 columns
    assert all(word in console for word in ("Tail", "Classical", "Real-only", "p = "))


def test_low_resource_table(cli, fixtures_dir, tmp_path):
    out = tmp_path / "lr"
    code, stdout, _ = cli(
        "evaluate",
        "--dataset",
        fixtures_dir / "generic" / "dataset.yaml",
        "--protocol",
        "low-resource",
        "--budgets",
        "25,50",
        "--seeds",
        "2",
        "--backbones",
        "rf",
        "--jobs",
        "1",
        "-o",
        out,
    )
    assert code == 0, stdout
    results = json.loads((out / "results.json").read_text())
    assert sorted({r["budget"] for r in results["records"]}) == [25.0, 50.0]
    assert {r["seed"] for r in results["records"]} == {0, 1}
    assert all(s["n"] == 6 for s in results["summary"])  # 3 folds x 2 seeds
    assert "| RF | 25% |" in (out / "results.md").read_text()
    # outside a terminal (a log file) progress comes as timestamped lines, one per new record
    lines = [line for line in stdout.splitlines() if line.startswith("[")]
    assert re.fullmatch(r"\[0:0\d\] my_waist_phone low-resource", lines[0])
    assert re.fullmatch(r"\[\d+:\d\d\] .*: seed 1 fold p3 50% real/rf: Macro-F1 \d+\.\d\d 12/12", lines[-1])
    assert len(lines) == 13


def test_a_method_short_of_its_budget_is_named():
    from vsmp_imu.cli.har import _shortfalls

    def row(method, got, asked, budget=None):
        return {"method": method, "protocol": "long-tail", "budget": budget, "backbone": "dclstm",
                "n_synthetic_mean": got, "n_synthetic_requested_mean": asked}

    lines = _shortfalls([row("real", 0, 0), row("real", 0, None), row("classical", 4190, 4190),
                         row("vsmp", 1084.2, 4190.4), row("vsmp", 96, 100, budget=5.0)])
    assert lines == ["vsmp (long-tail, dclstm) mixed in 1084 of the 4190 synthetic windows asked for "
                     "per run (26 %)"]


def test_refill_reaches_the_vsmp_method_only_when_asked(cli, fixtures_dir, tmp_path, monkeypatch):
    import vsmp_imu.methods as methods

    seen = []

    def recorder(name, **params):
        seen.append(params)
        raise SystemExit(0)  # stop before any generation: only the parameters matter here

    monkeypatch.setattr(methods, "make", recorder)
    args = ("evaluate", "--dataset", fixtures_dir / "generic" / "dataset.yaml", "--methods", "vsmp",
            "--backbones", "rf", "-o", tmp_path / "out")
    cli(*args, "--refill", "2")
    cli(*args)
    assert [p.get("refill") for p in seen] == [2, None]
    code, _, err = cli(*args, "--refill", "9")
    assert code == 2 and "--refill" in err


def test_jobs_reach_every_forest_and_the_networks_threads():
    from vsmp_imu.cli.har import _backbone_params

    params = _backbone_params(("rf", "rf-seg", "dclstm"), max_epochs=None, patience=None, jobs=3, device="cpu")
    assert params == {"rf": {"n_jobs": 3}, "rf-seg": {"n_jobs": 3}, "dclstm": {"n_threads": 3}}
    assert _backbone_params(("rf-seg",), None, None, None, "cpu") == {}


def test_a_registered_backbone_gets_the_options_its_parameters_name(monkeypatch):
    from dataclasses import dataclass

    from vsmp_imu.cli.har import _backbone_params
    from vsmp_imu.har.backbones import BACKBONES, RandomForestECDF

    @dataclass(eq=False, repr=False)
    class WideForest(RandomForestECDF):
        n_estimators: int = 300

    monkeypatch.setitem(BACKBONES, "rf-wide", WideForest)
    params = _backbone_params(("rf-wide", "rf"), max_epochs=5, patience=None, jobs=2, device="cpu")
    assert params == {"rf-wide": {"n_jobs": 2}, "rf": {"n_jobs": 2}}  # a forest takes no epochs


def test_class_weight_reaches_the_forests_and_their_records(cli, fixtures_dir, tmp_path):
    from vsmp_imu.cli.har import _backbone_params

    assert _backbone_params(("rf", "rf-seg"), None, None, None, "cpu", "balanced") == {
        "rf": {"class_weight": "balanced"}, "rf-seg": {"class_weight": "balanced"}}
    assert _backbone_params(("rf", "dclstm"), None, None, None, "cpu", "none") == {}
    assert _backbone_params(("dclstm", "bilstm-attn"), None, None, None, "cpu", "balanced") == {
        "dclstm": {"class_weight": "balanced"}, "bilstm-attn": {"class_weight": "balanced"}}

    def digest(weight: str) -> str:
        out = tmp_path / weight
        args = ("evaluate", "--dataset", fixtures_dir / "generic" / "dataset.yaml", "--protocol", "long-tail",
                "--rho", "2", "--methods", "real", "--backbones", "rf", "--jobs", "1", "-o", out)
        code, stdout, _ = cli(*args, *(("--class-weight", weight) if weight != "default" else ()))
        assert code == 0, stdout
        digests = {json.loads(f.read_text())["settings_digest"] for f in out.rglob("records/**/*.json")}
        assert len(digests) == 1
        return digests.pop()

    # balanced is the default: Real-only's records are those written with it; `none` is the paper's forest
    assert digest("balanced") == digest("default") != digest("none")


def test_class_weight_is_refused_when_a_chosen_backbone_takes_none(monkeypatch):
    from dataclasses import dataclass

    from sklearn.base import BaseEstimator

    from vsmp_imu.cli.har import _backbone_params
    from vsmp_imu.har.backbones import BACKBONES

    @dataclass(eq=False, repr=False)
    class Plain(BaseEstimator):
        depth: int = 2

    monkeypatch.setitem(BACKBONES, "plain", Plain)
    with pytest.raises(ConfigError, match="take no class weights") as caught:
        _backbone_params(("rf", "plain"), None, None, None, "cpu", "balanced")
    assert caught.value.field == "--class-weight" and "class_weight parameter" in caught.value.allowed
    assert _backbone_params(("rf", "plain"), None, None, None, "cpu", "none") == {}


def test_the_weights_default_to_balanced_classes_and_half_weight_synthetic_windows(monkeypatch, capsys):
    from dataclasses import dataclass

    from vsmp_imu.cli.har import weighting
    from vsmp_imu.har.backbones import BACKBONES, RandomForestECDF

    assert weighting(("rf", "dclstm"), None, None) == ("balanced", 0.5)
    assert weighting(("rf",), "none", None) == ("none", None)
    assert weighting(("rf",), None, "off") == ("balanced", None)  # balanced alone
    assert weighting(("rf",), "balanced", "0.25") == ("balanced", 0.25)
    for bad in ("half", "0", "nan", "-1"):
        with pytest.raises(ConfigError) as caught:
            weighting(("rf",), None, bad)
        assert caught.value.field == "--synthetic-weight"

    @dataclass(eq=False, repr=False)
    class Unweighable(RandomForestECDF):  # takes class weights, but its fit no window weights
        def fit(self, X, y, X_val=None, y_val=None):
            return super().fit(X, y, X_val, y_val)

    monkeypatch.setitem(BACKBONES, "rf-unweighable", Unweighable)
    assert weighting(("rf", "rf-unweighable"), None, None) == ("none", None)
    assert "rf-unweighable" in capsys.readouterr().out  # the fallback is said, not silent
    assert weighting(("rf", "rf-unweighable"), "balanced", None) == ("balanced", 0.5)  # refused by the check


def test_a_library_that_is_a_file_is_refused_by_every_command_that_takes_one(cli, tmp_path):
    a_file = tmp_path / "walk.yaml"
    a_file.write_text("name: walk\n")
    for argv in (("evaluate", "--dataset", "hapt", "--methods", "real", "-o", tmp_path / "out"),
                 ("smp", "library", "list"), ("motion", "synth", "walking", "--seed", "0", "-o", tmp_path / "m.npz"),
                 ("study", "ablation", "--dataset", "hapt12", "-o", tmp_path / "study")):
        code, _, err = cli(*argv, "--library", a_file)
        assert code == 2 and "field '--library': is not a folder" in err, (argv, err)
    assert not any((tmp_path / name).exists() for name in ("out", "m.npz", "study"))
