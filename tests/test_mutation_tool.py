"""tools/mutation.py: which survivors excluded.json argues, and its guard against renumbered mutants."""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[1] / "tools" / "mutation.py"
_spec = importlib.util.spec_from_file_location("mutation_tool", _PATH)
mutation = importlib.util.module_from_spec(_spec)
sys.modules["mutation_tool"] = mutation  # dataclasses look their module up there
_spec.loader.exec_module(mutation)

A, B = "pkg.mod.x_f__mutmut_1", "pkg.mod.x_f__mutmut_2"


def _rules(**diffs):
    rule = {"kind": "equivalent", "why": "argued", "mutants": [A, "pkg.mod.x_g__mutmut_*"]}
    if diffs:
        rule["diffs"] = diffs
    return [rule]


def test_a_rule_matches_by_name_and_a_pinned_rule_only_its_diff():
    assert mutation._exclusion(A, _rules()) is not None
    assert mutation._exclusion("pkg.mod.x_g__mutmut_7", _rules(), "- a\n+ b") is not None  # a pattern
    assert mutation._exclusion(B, _rules()) is None
    pinned = _rules(**{A: "- x = 1\n+ x = 2"})
    assert mutation._exclusion(A, pinned, "- x = 1\n+ x = 2") is not None
    assert mutation._exclusion(A, pinned) is not None  # diff unknown (before a run's diffs are read)
    assert mutation._exclusion(A, pinned, "- y = 1\n+ y = 0") is None  # renumbered: another mutant now
    assert mutation._stale(A, pinned, "- y = 1\n+ y = 0") and not mutation._stale(A, pinned, "- x = 1\n+ x = 2")


@pytest.fixture
def records(tmp_path, monkeypatch):
    monkeypatch.setattr(mutation, "RECORDS", tmp_path)
    monkeypatch.setattr(mutation, "EXCLUDED", tmp_path / "excluded.json")
    monkeypatch.setattr(mutation, "GROUPS", (mutation.Group("g", ("mod.py",), ("tests",)),))
    record = {"group": "g", "files": [], "tests": [], "tool": "mutmut", "date": "2026-12-07", "minutes": 1.0,
              "outcomes": {A: "survived", B: "survived", "pkg.mod.x_h__mutmut_1": "killed"},
              "survivors": {A: "- x = 1\n+ x = 2", B: "- z = 1\n+ z = 3"}}
    (tmp_path / "g.json").write_text(json.dumps(record))
    return tmp_path


def test_pin_stores_the_current_diff_of_each_argued_survivor_once(records):
    (records / "excluded.json").write_text(json.dumps(_rules()))
    assert mutation.pin(list(mutation.GROUPS)) == 1
    rules = json.loads((records / "excluded.json").read_text())
    assert rules[0]["diffs"] == {A: "- x = 1\n+ x = 2"}  # B is argued by no rule
    assert mutation.pin(list(mutation.GROUPS)) == 0  # already pinned


def test_the_report_counts_a_renumbered_mutant_as_a_survivor_and_flags_it(records):
    (records / "excluded.json").write_text(json.dumps(_rules(**{A: "- old\n+ argued"})))
    text = mutation.report()
    assert "| g | 33.3 % | 1 | 2 | 0 |" in text
    assert "Argued in excluded.json for another diff" in text and "`x_f__mutmut_1`" in text
    (records / "excluded.json").write_text(json.dumps(_rules(**{A: "- x = 1\n+ x = 2"})))
    text = mutation.report()
    assert "| g | 50.0 % | 1 | 1 | 1 |" in text and "Argued in excluded.json for another diff" not in text


def test_remap_follows_a_renumbered_argued_mutant_by_its_diff_and_drops_one_gone(records):
    moved_to, gone = "pkg.mod.x_f__mutmut_3", "pkg.mod.x_f__mutmut_9"
    record = json.loads((records / "g.json").read_text())
    record["outcomes"].update({moved_to: "survived", A: "killed"})  # number 1 is another mutant now
    record["survivors"] = {moved_to: "- x = 1\n+ x = 2", B: "- z = 1\n+ z = 3"}  # A's diff is now number 3
    (records / "g.json").write_text(json.dumps(record))
    rules = _rules(**{A: "- x = 1\n+ x = 2"})
    rules.append({"kind": "equivalent", "why": "gone", "mutants": [gone], "diffs": {gone: "- w\n+ v"}})
    rules.append({"kind": "equivalent", "why": "other", "mutants": ["other.x_k__mutmut_1"],
                  "diffs": {"other.x_k__mutmut_1": "- k\n+ j"}})  # another group's: left alone
    (records / "excluded.json").write_text(json.dumps(rules))
    assert mutation.remap(list(mutation.GROUPS)) == (1, 1)
    after = json.loads((records / "excluded.json").read_text())
    assert [r["why"] for r in after] == ["argued", "other"]  # the rule left empty is gone
    assert after[0]["mutants"] == ["pkg.mod.x_g__mutmut_*", moved_to] and after[0]["diffs"] == {moved_to: "- x = 1\n+ x = 2"}
    assert after[1] == rules[2]
    assert mutation.remap(list(mutation.GROUPS)) == (0, 0)  # nothing left to follow
    assert "| g | 66.7 % | 2 | 1 | 1 |" in mutation.report()


def test_a_rerun_records_the_runs_minutes_plus_its_own_not_the_time_since_the_run_began(records, tmp_path,
                                                                                        monkeypatch):
    build = tmp_path / "build"
    where = build / "g"
    (where / "tests").mkdir(parents=True)
    (where / "pyproject.toml").write_text('[tool.mutmut]\npytest_add_cli_args_test_selection = ["tests"]\n')
    (where / "mutmut.log").write_text("")
    began = time.time() - 3 * 3600  # the run began three hours ago
    os.utime(where / "pyproject.toml", (began, began))
    monkeypatch.setattr(mutation, "BUILD", build)
    monkeypatch.setattr(mutation, "ROOT", tmp_path)
    (tmp_path / "tests").mkdir()
    outcomes = {A: "survived", "pkg.mod.x_h__mutmut_1": "killed"}
    monkeypatch.setattr(mutation, "_outcomes", lambda where: dict(outcomes))
    monkeypatch.setattr(mutation, "_diffs", lambda where, names: {n: "- a\n+ b" for n in names})
    monkeypatch.setattr(mutation, "_select_tests", lambda where, group: None)
    monkeypatch.setattr(mutation, "_mutmut", lambda where, names: outcomes.update({A: "killed"}))
    record = mutation.rerun(mutation.GROUPS[0])
    assert record["outcomes"][A] == "killed"
    assert record["minutes"] == pytest.approx(1.0, abs=0.1)  # the fixture's run took a minute
    assert json.loads((records / "g.json").read_text())["minutes"] == record["minutes"]
    assert mutation.collect(mutation.GROUPS[0])["minutes"] == pytest.approx(180.0, abs=1.0)  # a run's own span
