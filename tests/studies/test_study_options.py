"""`vsmp-imu study ...` options checked before any work: a mistake exits with code 2 and a
message that names the option the user typed and what it allows."""

from __future__ import annotations

import pytest

from vsmp_imu.studies.control import ControlStudy

CONTROL_RUN = ControlStudy.run
STUDIES = {"control": "ControlStudy", "ablation": "AblationStudy", "granularity": "GranularityStudy",
           "realism": "RealismStudy", "case": "CaseStudy", "audit": "ExtractionAudit"}


@pytest.fixture(autouse=True)
def no_work(monkeypatch):
    """A study that starts its work fails the test at once (a check came too late)."""
    import importlib

    def started(*_args, **_kwargs):
        raise AssertionError("the study started its work before the options were checked")

    for module, cls in STUDIES.items():
        monkeypatch.setattr(getattr(importlib.import_module(f"vsmp_imu.studies.{module}"), cls), "run", started)
    monkeypatch.setattr("vsmp_imu.studies.audit.load_audit_inputs", started)


@pytest.mark.parametrize("args, says", [
    (("control", "--seeds", "100000000"), "'--seeds': must be an integer in 1..1000, not 100000000"),
    (("realism", "--seed", "-1"), "'--seed': must be an integer in 0..4294967295, not -1"),
    (("realism", "--seed", str(2**32)), "'--seed': must be an integer in 0..4294967295, not 4294967296"),
    (("realism", "--filters", "2000000000"), "'--filters': must be an integer in 1..1024, not 2000000000"),
    (("realism", "--hidden", "100000"), "'--hidden': must be an integer in 1..2048, not 100000"),
    (("realism", "--batch-size", "1000000"), "'--batch-size': must be an integer in 1..4096, not 1000000"),
    (("realism", "--max-per-class", "1000000"), "'--max-per-class': must be an integer in 1..100000, not 1000000"),
    (("realism", "--epochs", "1000000"), "'--epochs': must be an integer in 1..100000, not 1000000"),
    (("realism", "--jobs", "1000"), "'--jobs': must be an integer in 1..256, not 1000"),
    (("realism", "--encoder-windows", "-3"), "'--encoder-windows': must be an integer >= 0, not -3"),
    (("realism", "--alpha", "0"), "'--alpha': must be a finite number in 0.1..2, not 0"),
    (("case", "--activity", "walking", "--seed", "-1"), "'--seed': must be an integer in 0..4294967295, not -1"),
    (("ablation", "--parts", "alpha", "--k", "0"), "'--k': must be an integer in 1..64, not 0"),
    (("ablation", "--max-rounds", "1000"), "'--max-rounds': must be an integer in 1..100, not 1000"),
    (("ablation", "--seeds", "1001"), "'--seeds': must be an integer in 1..1000, not 1001"),
    (("ablation", "--jobs", "1000"), "'--jobs': must be an integer in 1..256, not 1000"),
    (("ablation", "--alpha", "5"), "'--alpha': must be a finite number in 0.1..2, not 5"),
    (("ablation", "--alphas", "0.5,3"), "'--alphas': each value must be a finite number in 0.1..2, not '3'"),
    (("ablation", "--alphas", "0.5,half"), "'--alphas': each value must be a finite number in 0.1..2, not 'half'"),
    (("ablation", "--budget", "0"), "'--budget': must be a finite number in 0.01..100, not 0"),
    (("ablation", "--budget", "1e-09"), "'--budget': must be a finite number in 0.01..100, not 1e-09"),
    (("granularity", "--workers", "0"), "'--workers': must be an integer in 1..256, not 0"),
    (("granularity", "--k", "0"), "'--k': must be an integer in 1..64, not 0"),
    (("granularity", "--max-epochs", "0"), "'--max-epochs': must be an integer in 1..100000, not 0"),
    (("granularity", "--alpha", "nan"), "'--alpha': must be a finite number in 0.1..2, not nan"),
    (("granularity", "--protocol", "low-resource", "--budget", "inf"),
     "'--budget': must be a finite number in 0.01..100, not inf"),
    (("audit", "--pred", "p", "--ref", "r", "--min-valid", "101"), "'--min-valid': must be an integer in 1..100, not 101"),
])
def test_a_number_out_of_range_is_refused_before_any_work(cli, tmp_path, args, says):
    """Each number option's range is its callback's (cli.common), in the common wording."""
    code, _, err = cli("study", args[0], "-o", tmp_path / "out", *args[1:])
    assert code == 2
    assert f"Invalid value for {says}" in " ".join(err.replace("│", " ").split()), err  # the box unwrapped
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("study", ["ablation", "granularity"])
@pytest.mark.parametrize("protocol", ["tstr", "unseen"])
def test_a_protocol_the_study_does_not_offer_is_refused(cli, tmp_path, study, protocol):
    code, _, err = cli("study", study, "-o", tmp_path / "out", "--protocol", protocol)
    assert code == 2
    assert "field '--protocol'" in err and "Allowed: lopo, low-resource, long-tail" in err, err


@pytest.mark.parametrize("study, protocol", [("ablation", "lopo"), ("granularity", "lopo"),
                                             ("granularity", "long-tail")])
def test_a_budget_the_protocol_ignores_is_refused(cli, tmp_path, study, protocol):
    code, _, err = cli("study", study, "-o", tmp_path / "out", "--protocol", protocol, "--budget", "5")
    assert code == 2
    assert "field '--budget'" in err and "low-resource protocol only" in err, err


def test_the_ablation_budget_defaults_to_five_percent_under_low_resource(monkeypatch, cli, tmp_path):
    from vsmp_imu.studies.ablation import AblationStudy

    seen = {}

    def run(self, *_args, **_kwargs):
        seen["budget"] = self.budget
        raise AssertionError("stop")

    monkeypatch.setattr(AblationStudy, "run", run)
    with pytest.raises(AssertionError, match="stop"):
        cli("study", "ablation", "-o", tmp_path / "out")
    assert seen == {"budget": 5.0}


@pytest.mark.parametrize("args, option", [
    (("case", "--activity", "no_such_activity"), "--activity"),
    (("case", "--activity", "walking", "--location", "no_such_place"), "--location"),
    (("control", "--backend", "foo"), "--backend"),
    (("granularity", "--backend", "foo"), "--backend"),
    (("ablation", "--backend", "foo"), "--backend"),
    (("granularity", "--source", "foo"), "--source"),
    (("realism", "--source", "smp:"), "--source"),
    (("realism", "--source", "smp:/no/such/folder"), "--source"),
])
def test_an_error_names_the_option_the_user_typed(cli, tmp_path, args, option):
    code, _, err = cli("study", args[0], "-o", tmp_path / "out", *args[1:])
    assert code == 2
    assert f"field '{option}'" in err, err


def test_an_unknown_control_activity_names_the_option(monkeypatch, cli, tmp_path):
    monkeypatch.setattr(ControlStudy, "run", CONTROL_RUN)  # the activities are checked as it starts
    code, _, err = cli("study", "control", "-o", tmp_path / "out", "--activities", "walk")
    assert code == 2
    assert "field '--activities'" in err, err


@pytest.mark.parametrize("study", ["ablation", "granularity"])
def test_the_shared_run_options_reach_the_study(monkeypatch, cli, tmp_path, study):
    """--backend, --workers, --library and the backbone's --max-epochs, --patience and --jobs
    (one definition, `run_options`) reach the study's generation spec and backbone."""
    import importlib

    seen = {}

    def run(self, *_args, **_kwargs):
        seen.update(options=self.options, backbone_params=self.backbone_params)
        raise AssertionError("stop")

    module = importlib.import_module(f"vsmp_imu.studies.{study}")
    monkeypatch.setattr(getattr(module, STUDIES[study]), "run", run)
    library = tmp_path / "lib"
    library.mkdir()
    with pytest.raises(AssertionError, match="stop"):
        cli("study", study, "-o", tmp_path / "out", "--backbone", "dclstm", "--backend", "compiled",
            "--workers", "2", "--max-epochs", "3", "--patience", "2", "--jobs", "4", "--library", library)
    options = seen["options"]
    assert (options.backend, options.workers, options.library_dirs) == ("compiled", 2, (str(library),))
    assert seen["backbone_params"] == {"n_threads": 4, "max_epochs": 3, "patience": 2}


@pytest.mark.parametrize("study, others", [("granularity", "real,vsmp"), ("realism", "vsmp,classical")])
@pytest.mark.parametrize("args, option, says", [
    (("--describer-url", "http://localhost:8000/v1"), "--describer-url", "only the imugpt method asks"),
    (("--methods", "imugpt", "--describer-model", "writer"), "--describer-model", "--describer-url URL"),
    (("--methods", "imugpt", "--describer-url", "localhost:8000/v1"), "--describer-url", "not the URL"),
    (("--methods", "imugpt", "--describer-url", "ftp://host/v1"), "--describer-url", "not the URL"),
])
def test_a_describer_is_refused_before_any_work(cli, tmp_path, study, others, args, option, says):
    """As `evaluate`'s (`cli.common.describer_options`): a describer without imugpt among
    --methods, a model without a URL, a URL that names no endpoint."""
    methods = () if "--methods" in args else ("--methods", others)
    code, _, err = cli("study", study, "-o", tmp_path / "out", *methods, *args)
    assert code == 2
    assert f"field '{option}'" in err and says in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("study", ["granularity", "realism"])
def test_the_describer_reaches_the_study_as_imugpts_options(monkeypatch, cli, tmp_path, study):
    import importlib

    seen = {}

    def run(self, *_args, **_kwargs):
        seen["method_options"] = self.method_options
        raise AssertionError("stop")

    module = importlib.import_module(f"vsmp_imu.studies.{study}")
    monkeypatch.setattr(getattr(module, STUDIES[study]), "run", run)
    with pytest.raises(AssertionError, match="stop"):
        cli("study", study, "-o", tmp_path / "out", "--describer-url", "http://localhost:8000/v1")
    assert seen == {"method_options": {"imugpt": {"describer_url": "http://localhost:8000/v1",
                                                  "describer_model": ""}}}
