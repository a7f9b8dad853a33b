"""`vsmp-imu evaluate`: its options checked before the dataset loads."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest


@pytest.fixture
def generic(fixtures_dir, tmp_path) -> Path:
    """A copy of the generic fixture dataset (its data may be edited); its dataset.yaml."""
    shutil.copytree(fixtures_dir / "generic", tmp_path / "generic")
    return tmp_path / "generic" / "dataset.yaml"


def _evaluate(cli, dataset, out, *args):
    return cli("evaluate", "--dataset", dataset, "--folds", "p1", "--jobs", "1", *args, "-o", out)


@pytest.mark.parametrize("args,option", [
    (("--methods", "real,classical,real"), "--methods"),
    (("--backbones", "rf,rf"), "--backbones"),
    (("--folds", "p1,p1"), "--folds"),
    (("--protocol", "low-resource", "--budgets", "5,5%"), "--budgets"),
    (("--protocol", "unseen", "--unseen", "walk,walk"), "--unseen"),
])
def test_a_value_named_twice_is_refused(cli, generic, tmp_path, args, option):
    code, stdout, err = cli("evaluate", "--dataset", generic, "--jobs", "1", *args, "-o", tmp_path / "run")
    assert code == 2 and f"field '{option}'" in err and "named more than once" in err, stdout
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("args,option,allowed", [
    (("--backend", "foo"), "--backend", "procedural, compiled, hymotion"),
    (("--device", "foo"), "--device", "cpu, cuda, cuda:N, mps, auto"),
])
def test_options_no_chosen_part_uses_are_still_checked(cli, generic, tmp_path, args, option, allowed):
    code, stdout, err = _evaluate(cli, generic, tmp_path / "run", *args)
    assert code == 2 and f"field '{option}'" in err and allowed in err, stdout
    assert not (tmp_path / "run").exists()


def test_a_device_no_backbone_uses_is_said_to_be_unused(monkeypatch, capsys):
    from vsmp_imu.cli.har import _backbone_params

    assert _backbone_params(("rf",), None, None, 1, "cuda:1") == {"rf": {"n_jobs": 1}}
    assert "--device is unused" in capsys.readouterr().out
