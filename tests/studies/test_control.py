"""The controllability study: protocol plan, a small run at three checkpoints, outputs, CLI."""

from __future__ import annotations

import importlib.util
import json
from collections import Counter

import pytest
from study_support import SMOKE_ACTIVITIES, UTD_DIR

from vsmp_imu.errors import ValidationError
from vsmp_imu.studies.control import (
    CONTROL_ACTIVITIES,
    ControlStudy,
    applicable_controls,
    imu_location,
    plan_cases,
    relative_values,
)
from vsmp_imu.studies.control_report import target_checks, write_control_outputs


def test_the_paper_protocol_has_580_motions(library):
    cases = plan_cases(library)
    assert len(cases) == 580
    counts = Counter(c.attribute for c in cases)
    assert counts == {"tempo": 180, "amplitude": 180, "repetitions": 120, "duration": 60, "symmetry": 40}
    assert {c.activity for c in cases if c.attribute == "duration"} == {
        "right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge"}
    assert [imu_location(a) for a in CONTROL_ACTIVITIES].count("right_thigh") == 4


def test_controls_of_other_utd_activities_follow_their_smp(library):
    bowling = applicable_controls(library.get("bowling"))
    assert "tempo" in bowling and "repetitions" not in bowling
    with pytest.raises(ValidationError, match="not a UTD-MHAD activity"):
        plan_cases(library, activities=["jumping_jacks"])
    with pytest.raises(ValidationError, match="unknown control"):
        plan_cases(library, attributes=["speed"])


def test_smoke_run_measures_every_control_at_every_checkpoint(smoke_run):
    _, results = smoke_run
    s = results.summary
    assert results.settings["n_motions"] == 22 and len(results.cases) == 22
    assert set(s) == {"tempo", "amplitude", "repetitions", "duration", "symmetry"}
    for attribute in ("tempo", "amplitude"):
        for cp in ("motion", "raw_imu", "grounded_imu"):
            assert s[attribute]["checkpoints"][cp]["rho_per_set"] >= 0.8, (attribute, cp)
    reps = s["repetitions"]["checkpoints"]
    assert reps["motion"]["within_one"] == 1.0 and reps["raw_imu"]["within_one"] == 1.0
    assert s["duration"]["checkpoints"]["motion"]["mape"] < 0.05
    assert s["duration"]["checkpoints"]["raw_imu"]["mape"] < 0.08
    sym = s["symmetry"]["checkpoints"]["motion"]
    assert sym["accuracy"] == 1.0 and sym["confusion"]["matrix"] == [[2, 0], [0, 2]]
    assert "raw_imu" not in s["symmetry"]["checkpoints"]  # symmetry is a motion-only control
    assert results.grounding["target"] == "hapt"
    assert results.grounding["convention"]["axes"] == ["up", "forward", "left"]
    assert results.retention["per_control"]["tempo"]["template"] == 1.0


def test_amplitude_energy_is_relative_to_the_medium_level(smoke_run):
    _, results = smoke_run
    amp = [r for r in results.cases if r.case.attribute == "amplitude"]
    medium = [r for r in amp if r.case.level == "medium"]
    assert all(r.values["raw_imu"] == pytest.approx(1.0) for r in medium)
    rel = relative_values(amp, "motion")
    for r, v in zip(amp, rel, strict=True):
        if r.case.level == "medium":
            assert v == pytest.approx(1.0)
    small = [r.values["grounded_imu"] for r in amp if r.case.level == "small"]
    large = [r.values["grounded_imu"] for r in amp if r.case.level == "large"]
    assert max(small) < 1.0 < min(large)


def test_levels_of_a_set_share_the_seed_and_the_sensor(smoke_run):
    _, results = smoke_run
    tempo = [r for r in results.cases if r.case.attribute == "tempo" and r.case.activity == "two_arm_curl"]
    assert {r.case.seed for r in tempo} == {0} and {r.location for r in tempo} == {"right_wrist"}
    durations = [r.duration_s for r in sorted(tempo, key=lambda r: ["slow", "medium", "fast"].index(r.case.level))]
    assert durations[0] > durations[1] > durations[2]
    assert all("two arm curl" in r.prompt for r in tempo)


def test_same_seed_same_bytes_and_the_cache_is_used(smoke_run, tmp_path, library):
    out, first = smoke_run
    paths = write_control_outputs(first, out)
    again = ControlStudy(seeds=[0], activities=SMOKE_ACTIVITIES, library=library).run(tmp_path)
    write_control_outputs(again, tmp_path)
    assert (tmp_path / "cases.csv").read_text() == paths["cases"].read_text()
    n_cached = len(list((out / "cache").glob("*.npz")))
    rerun = ControlStudy(seeds=[0], activities=SMOKE_ACTIVITIES, library=library).run(out)
    assert len(list((out / "cache").glob("*.npz"))) == n_cached  # nothing new generated
    assert [r.row() for r in rerun.cases] == [r.row() for r in first.cases]


def test_outputs(smoke_run):
    out, results = smoke_run
    paths = write_control_outputs(results, out)
    report = paths["report"].read_text()
    for text in ("| Control | Motion agreement | Motion compliance | Raw-IMU agreement",
                 "## Targets", "## Label retention", "control_results.png", "waist phone"):
        assert text in report
    data = json.loads(paths["results"].read_text())
    assert data["study"] == "controllability" and len(data["cases"]) == 22
    assert {t["check"] for t in data["targets"]} >= {"duration MAPE (motion)", "tempo grounded-IMU rho"}
    png = paths["figure"].read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 50_000
    header = paths["cases"].read_text().splitlines()[0]
    assert header.startswith("attribute,activity,level,seed,location,motion,raw_imu,grounded_imu")


def test_target_check_reports_activities_below(smoke_run):
    _, results = smoke_run
    checks = {c["check"]: c for c in target_checks(results)}
    mape = checks["duration MAPE (motion)"]
    assert mape["met"] == (mape["value"] <= 0.05)
    assert set(mape["activities_missing_target"]) <= {"two_hand_push"}


def test_utd_mhad_grounding_and_validator(tmp_path, library):
    """The UTD-MHAD path on the fixture files (synthetic values in the published format)."""
    results = ControlStudy(seeds=[0], activities=["jogging_in_place"], attributes=["tempo"],
                           library=library, data_dir=UTD_DIR).run(tmp_path)
    g = results.grounding
    assert g["target"] == "utd-mhad" and set(g["locations"]) == {"right_thigh"}
    assert len(g["locations"]["right_thigh"]["inferred_axes"]) == 3
    for r in results.cases:  # grounded to the fixture's statistics: the signal changed
        assert r.grounded["acc_ptp"] != pytest.approx(r.raw["acc_ptp"], rel=0.05)
    assert all(r.validator_label is not None for r in results.cases)
    assert "validator" in results.retention["per_control"]["tempo"]


def test_cli(cli, tmp_path):
    code, out, err = cli("study", "control", "-o", tmp_path, "--seeds", "1", "--activities",
                         "two_hand_push", "--controls", "duration")
    assert code == 0, err
    assert "duration: motion MAPE" in out and (tmp_path / "report.md").exists()
    code, _, err = cli("study", "control", "-o", tmp_path, "--controls", "speed")
    assert code == 2 and "speed" in err
    code, _, err = cli("study", "control", "-o", tmp_path, "--activities", "moonwalk")
    assert code == 2 and "moonwalk" in err
    code, _, err = cli("study", "control", "-o", tmp_path, "--seeds", "0")
    assert code == 2 and "--seeds" in err
    if importlib.util.find_spec("hymotion") is None:  # no HY-Motion here: a clear message
        code, _, err = cli("study", "control", "-o", tmp_path / "hy", "--seeds", "1", "--activities",
                           "two_arm_curl", "--controls", "tempo", "--backend", "hymotion")
        assert code == 2 and "HY-Motion" in err


@pytest.mark.slow
def test_full_protocol_meets_the_targets(tmp_path, library):
    """The paper's 580 motions (about 20 s): the targets of docs/studies.md."""
    results = ControlStudy(library=library).run(tmp_path)
    assert len(results.cases) == 580
    checks = {c["check"]: c for c in target_checks(results)}
    assert len(checks) == 9
    missed = {name: c["value"] for name, c in checks.items() if not c["met"]}
    assert not missed
