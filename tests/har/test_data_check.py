"""`vsmp-imu data check`: an activity file that does not describe its class is flagged."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
import yaml

from vsmp_imu.imu import ImuSimulator
from vsmp_imu.pipeline.check import SIDE_FROM_EVIDENCE
from vsmp_imu.pipeline.sample import backend_for
from vsmp_imu.smp import save_smp
from vsmp_imu.smp.library import ActivityLibrary

# waist phone: x up, y left, z backward (body words); device = P @ segment (left, up, forward)
P = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1]])


def _dataset(root, library, turn=np.eye(3), labels=("walking", "sitting")) -> object:
    """Two subjects' simulated windows in the device frame P (then turned by `turn`, a sensor
    sitting askew on the body)."""
    backend = backend_for("procedural", ())
    rows = []
    for n, subject in enumerate(["a", "b"]):
        for k, label in enumerate(labels):
            imu = ImuSimulator(50.0, seed=n).simulate(backend.generate(library.get(label).smp, 20 + 2 * n + k),
                                                      "waist").data
            acc, gyr = imu[:, :3] @ P.T @ turn.T, imu[:, 3:] @ P.T @ turn.T
            rows.append(pd.DataFrame({"subject": subject, "label": label, "ax": acc[:, 0], "ay": acc[:, 1],
                                      "az": acc[:, 2], "gx": gyr[:, 0], "gy": gyr[:, 1], "gz": gyr[:, 2]}))
    (root / "data").mkdir(parents=True)
    pd.concat(rows).to_csv(root / "data" / "all.csv", index=False)
    spec = {"name": "my_phone", "data": "data", "fs_hz": 50, "locations": [
        {"name": "waist", "acc": ["ax", "ay", "az"], "gyr": ["gx", "gy", "gz"], "acc_unit": "m/s^2",
         "gyr_unit": "rad/s", "axes": ["up", "left", "backward"]}]}
    (root / "dataset.yaml").write_text(yaml.safe_dump(spec))
    return root / "dataset.yaml"


def test_a_wrong_activity_file_is_flagged_and_the_right_one_is_not(cli, tmp_path):
    library = ActivityLibrary.load()
    path = _dataset(tmp_path / "ds", library)
    smps = tmp_path / "smps"
    smps.mkdir()
    save_smp(library.get("walking").smp, smps / "walking.json")
    wrong = library.get("jumping_jacks").smp.model_copy(update={"activity_label": "sitting"})
    save_smp(wrong, smps / "sitting.json")
    code, out, err = cli("data", "check", path, "--source", f"smp:{smps}", "--samples", "2", "-o", tmp_path / "chk")
    assert code == 0, err
    result = {c["label"]: c for c in json.loads((tmp_path / "chk" / "check.json").read_text())["classes"]}
    assert result["walking"]["flags"] == []
    assert result["walking"]["gravity_angle_deg"] < 20
    # the same motion on both sides: the same within-window shape; the real sitting does not move
    assert abs(result["walking"]["real_acc_skew"] - result["walking"]["synthetic_acc_skew"]) < 0.5
    assert result["sitting"]["real_acc_skew"] is None and result["sitting"]["synthetic_acc_skew"] is not None
    # a walking waist turns far more than a sitting one; the same motion on both sides turns alike
    assert result["walking"]["real_turn_rms"] > 3 * result["sitting"]["real_turn_rms"]
    assert abs(result["walking"]["real_turn_rms"] / result["walking"]["synthetic_turn_rms"] - 1) < 0.3
    assert result["sitting"]["flags"] and "moves" in " ".join(result["sitting"]["flags"])
    # a forest knows only the classes it was trained on: jumping jacks, unlike either, are still taken for one
    assert result["walking"]["taken_for"] == {"walking": 100.0}
    assert sum(result["sitting"]["taken_for"].values()) == pytest.approx(100.0)
    assert result["sitting"]["l_sim"] > 2 * result["walking"]["l_sim"]
    assert "sitting (waist, sitting.json)" in " ".join(out.split())
    assert (tmp_path / "chk" / "check.png").stat().st_size > 0
    # with the library's own files, nothing is off
    code, out, err = cli("data", "check", path, "--samples", "2", "-o", tmp_path / "chk2")
    written = json.loads((tmp_path / "chk2" / "check.json").read_text())
    assert code == 0 and [c["flags"] for c in written["classes"]] == [[], []] and written["warnings"] == []
    assert written["pairs"] == []  # real walking and sitting differ on every cue: no pair to check
    assert [c["recognised_pct"] for c in written["classes"]] == [100.0, 100.0]
    assert (tmp_path / "chk2" / "check_taken.png").read_bytes()[:4] == b"\x89PNG"


def test_wrong_axes_turn_gravity_away(cli, tmp_path):
    path = _dataset(tmp_path / "ds", ActivityLibrary.load())
    spec = yaml.safe_load(path.read_text())
    spec["locations"][0]["axes"] = ["left", "up", "forward"]  # not the phone's axes: a half turn away
    path.write_text(yaml.safe_dump(spec))
    code, out, err = cli("data", "check", path, "--samples", "1", "-o", tmp_path / "mounted")
    assert code == 0, err
    written = json.loads((tmp_path / "mounted" / "check.json").read_text())
    (mounting,) = written["mountings"]
    # the estimated mounting takes the half turn up, and says the axes look wrong
    assert mounting["angle_deg"] > 150 and mounting["flags"] and "check the axes" in mounting["flags"][0]
    assert "check the axes" in " ".join(out.split())
    assert all(c["gravity_angle_deg"] < 15 < 60 < c["declared_gravity_angle_deg"] for c in written["classes"])
    code, _, err = cli("data", "check", path, "--samples", "1", "--no-mounting", "-o", tmp_path / "chk")
    assert code == 0, err
    assert json.loads((tmp_path / "chk" / "check.json").read_text())["mountings"][0]["angle_deg"] is None
    del spec["locations"][0]["axes"]
    path.write_text(yaml.safe_dump(spec))
    code, _, err = cli("data", "check", path, "--samples", "1", "-o", tmp_path / "chk_none")
    warned = json.loads((tmp_path / "chk_none" / "check.json").read_text())["warnings"]
    assert code == 0 and "declares no axes" in err and len(warned) == 1
    classes = {c["label"]: c for c in json.loads((tmp_path / "chk" / "check.json").read_text())["classes"]}
    for label in ("sitting", "walking"):
        assert classes[label]["gravity_angle_deg"] > 60 and "gravity points" in classes[label]["flags"][0]


def test_a_sensor_askew_on_the_body_is_taken_up_by_the_mounting(cli, tmp_path):
    """A phone turned 35° about the body's long axis on the belt: the check estimates the turn,
    compares each class after it, and flags nothing; in the declared axes alone gravity and the
    turns of lying down differ."""
    from scipy.spatial.transform import Rotation

    turn = Rotation.from_rotvec(np.radians(35.0) * np.array([1.0, 0.0, 0.0])).as_matrix()  # device x = up
    path = _dataset(tmp_path / "ds", ActivityLibrary.load(), turn, labels=("walking", "sitting", "sit_to_lie"))
    code, out, err = cli("data", "check", path, "--samples", "2", "-o", tmp_path / "chk")
    assert code == 0, err
    written = json.loads((tmp_path / "chk" / "check.json").read_text())
    (mounting,) = written["mountings"]
    assert abs(mounting["angle_deg"] - 35.0) < 5 and mounting["axis"][0] > 0.97 and mounting["flags"] == []
    assert f"sits {mounting['angle_deg']:.0f}° from its declared axes" in " ".join(out.split())
    classes = {c["label"]: c for c in written["classes"]}
    assert all(c["flags"] == [] for c in classes.values()), classes
    assert classes["sit_to_lie"]["gravity_angle_deg"] < 8 < 20 < classes["sit_to_lie"]["declared_gravity_angle_deg"]
    code, _, err = cli("data", "check", path, "--samples", "2", "--no-mounting", "-o", tmp_path / "declared")
    declared = {c["label"]: c for c in json.loads((tmp_path / "declared" / "check.json").read_text())["classes"]}
    assert code == 0 and any("rotation rate" in f for f in declared["sit_to_lie"]["flags"])


def test_user_mistakes_exit_2(cli, tmp_path):
    path = _dataset(tmp_path / "ds", ActivityLibrary.load())
    code, _, err = cli("data", "check", path, "--source", f"smp:{tmp_path / 'nowhere'}", "-o", tmp_path / "c")
    assert code == 2 and err.startswith(f"{tmp_path / 'nowhere'}: field '--source': SMP source folder not found")
    code, _, err = cli("data", "check", tmp_path / "missing.yaml", "-o", tmp_path / "c")
    assert code == 2 and "missing.yaml" in err


@pytest.mark.parametrize(("args", "says"), [
    (("--overlap", "0.999"), "Invalid value for '--overlap': must be a finite number in 0..0.9, not 0.999"),
    (("--overlap", "-1"), "Invalid value for '--overlap': must be a finite number in 0..0.9, not -1"),
    (("--overlap", "nan"), "Invalid value for '--overlap': must be a finite number in 0..0.9, not nan"),
    (("--window-s", "0.1"), "Invalid value for '--window-s': must be a finite number in 0.5..30, not 0.1"),
    (("--backend", "mocap"), "field '--backend': unknown motion backend 'mocap'. "
                             "Allowed: procedural, compiled, hymotion."),
    (("--source", "youtube"), "field '--source': unknown source 'youtube'. Allowed: library, smp:DIR, video:DIR."),
    (("--source", "smp:"), "field '--source': source 'smp' needs a folder: smp:DIR."),
])
def test_bad_options_are_refused_before_the_dataset_loads(cli, tmp_path, args, says):
    """The bounds and words of `evaluate` (an overlap of 0.999 made a window every few samples: four
    minutes on HAPT); the missing dataset file would be the error if the dataset loaded first."""
    code, _, err = cli("data", "check", tmp_path / "missing.yaml", *args, "-o", tmp_path / "c")
    text = " ".join(err.replace("│", " ").split())
    assert code == 2 and says in text, text
    assert "missing.yaml" not in text and not (tmp_path / "c").exists()


def test_turning_the_other_way_is_flagged_and_the_same_way_is_not(cli, tmp_path):
    """Real windows of people lying down with a quarter turn to the left, against the library's file
    (a turn to the right) and against the same file turned left."""
    from vsmp_imu.pipeline.side import with_side

    library = ActivityLibrary.load()
    left = with_side(library.get("sit_to_lie").smp, "left")
    backend = backend_for("procedural", ())
    rows = []
    for n, subject in enumerate(["a", "b", "c"]):
        imu = ImuSimulator(50.0, seed=n).simulate(backend.generate(left, 40 + n), "waist").data
        acc, gyr = imu[:, :3] @ P.T, imu[:, 3:] @ P.T
        rows.append(pd.DataFrame({"subject": subject, "label": "sit_to_lie", "ax": acc[:, 0], "ay": acc[:, 1],
                                  "az": acc[:, 2], "gx": gyr[:, 0], "gy": gyr[:, 1], "gz": gyr[:, 2]}))
    path = _dataset(tmp_path / "ds", library)
    pd.concat(rows).to_csv(path.parent / "data" / "all.csv", index=False)
    smps = tmp_path / "smps"
    smps.mkdir()
    save_smp(left, smps / "sit_to_lie.json")
    flags = {}
    for name, extra in (("library", ()), ("left", ("--source", f"smp:{smps}"))):
        code, _, err = cli("data", "check", path, *extra, "--samples", "2", "-o", tmp_path / name)
        assert code == 0, err
        (result,) = json.loads((tmp_path / name / "check.json").read_text())["classes"]
        flags[name] = [f for f in result["flags"] if "one execution turns" in f]  # 3 labelled runs
        if name == "library":
            real, syn = np.array(result["real_mean_gyro"]), np.array(result["synthetic_mean_gyro"])
            # the mirror image: the rates about up and backward change sign, the pitch (about left) not
            assert np.sign(real[[0, 2]]).tolist() == (-np.sign(syn[[0, 2]])).tolist()
            assert abs(real[1] - syn[1]) < 0.25 * abs(real[1])
    assert len(flags["library"]) == 1
    assert flags["left"] == []
    # the library's file leaves the side to its variants: the flag says the generator takes it from the data
    assert flags["library"][0].endswith("check the side" + SIDE_FROM_EVIDENCE)


def test_the_turn_flag_needs_a_gap_beyond_the_floor_and_half_the_larger_turn():
    from vsmp_imu.pipeline.check import MIN_TURN_RAD_S, turn_flag

    axes = ("up", "left", "backward")
    assert turn_flag(np.zeros(3), np.array([0.0, 0.0, 0.9 * MIN_TURN_RAD_S]), axes) is None
    assert turn_flag(np.array([0.4, 0, 0]), np.array([0.25, 0, 0]), axes) is None  # same way, 0.15 < 0.2
    flag = turn_flag(np.array([0.4, 0, 0]), np.array([0.15, 0, 0]), axes)
    assert flag and "x (up): +0.40 rad/s real vs +0.15 simulated" in flag and "0.4x as far" in flag
    opposite = turn_flag(np.array([0, 0, -0.3]), np.array([0, 0, 0.3]), axes)
    assert "z (backward)" in opposite and opposite.endswith("check the side")
    free = turn_flag(np.array([0, 0, -0.3]), np.array([0, 0, 0.3]), axes, side_free=True)
    assert free == opposite + SIDE_FROM_EVIDENCE
    assert "the activity file lacks" in turn_flag(np.array([0.3, 0, 0]), np.zeros(3), axes)
    assert "the real windows lack" in turn_flag(np.zeros(3), np.array([0, 0.3, 0]), axes)


def test_acc_skew_tells_impacts_from_dips_and_ignores_still_windows():
    from vsmp_imu.pipeline.check import acc_skew

    rng = np.random.default_rng(0)
    base = np.zeros((20, 100, 6))
    base[..., 0] = 9.81
    base[..., :3] += rng.normal(0.0, 0.3, (20, 100, 3))
    spikes, dips = base.copy(), base.copy()
    spikes[:, 40:43, 0] += 6.0  # a short impact above g, as a heel strike or a seat
    dips[:, 40:43, 0] -= 6.0
    assert acc_skew(spikes) > 1.0 and acc_skew(dips) < -1.0
    still = np.zeros((5, 100, 6))
    still[..., 0] = 9.81
    assert acc_skew(still) is None


def test_two_harmonics_of_about_equal_power_are_one_rhythm():
    """A frequency flag needs the other side's peak to be weak here: a step-frequency peak beside a
    twice-per-step one of the same height is the same gait, whichever wins the argmax."""
    from vsmp_imu.pipeline.check import dominant_frequency, strong_at

    t = np.arange(100) / 50.0
    base = np.zeros((4, 100, 6))
    both, high = base.copy(), base.copy()
    both[..., 0] = 9.81 + 1.0 * np.sin(2 * np.pi * 2.0 * t) + 1.02 * np.sin(2 * np.pi * 4.0 * t)
    high[..., 0] = 9.81 + 1.0 * np.sin(2 * np.pi * 4.0 * t) + 0.3 * np.sin(2 * np.pi * 2.0 * t)
    assert dominant_frequency(both, 50.0) == 4.0 and dominant_frequency(high, 50.0) == 4.0
    assert strong_at(both, 50.0, 2.0) and not strong_at(high, 50.0, 2.0)


def test_executions_turning_either_way_are_no_gap_but_the_other_way_is():
    """A stairwell's executions each turn to a drawn side: their class mean cancels, while every real
    window turns left; as long as the simulated windows turn as much either way, nothing is flagged."""
    from vsmp_imu.har.dataset import SensorLocation
    from vsmp_imu.pipeline.check import compare, turns_either_way

    rng = np.random.default_rng(0)
    loc = SensorLocation(name="waist", channels=("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"),
                         axes=("up", "forward", "left"), gravity_included=True, acc_unit="m/s^2", gyr_unit="rad/s")

    def windows(turns):
        out = rng.normal(0.0, 0.2, size=(len(turns), 100, 6))
        out[..., 0] += 9.81
        out[..., 3] += np.asarray(turns)[:, None]
        return out

    real = windows([0.5] * 20 + [0.0] * 20)
    either = windows([0.5] * 10 + [-0.5] * 10 + [0.0] * 20)
    other = windows([-0.5] * 20 + [0.0] * 20)
    assert turns_either_way(either) and not turns_either_way(other) and not turns_either_way(real)

    def turn_flags(syn):
        return [f for f in compare("stairs", loc, "x", real, syn, 50.0).flags if "rotation" in f]

    assert turn_flags(either) == []
    assert "check the side" in turn_flags(other)[0]
    assert "lacks" in turn_flags(windows([0.05] * 40))[0]  # no turn at all is still a gap


def _pair_windows(rng, n, shift_q1=0.0, shift_mean=0.0):
    """n windows (T=40, 2 channels) of noise; channel 0's first quarter raised by `shift_q1`,
    channel 1 raised by `shift_mean`."""
    w = rng.normal(0.0, 1.0, (n, 40, 2))
    w[:, :10, 0] += shift_q1
    w[:, :, 1] += shift_mean
    return w


def test_a_pair_the_simulation_tells_apart_by_a_cue_the_real_windows_lack_is_flagged():
    from vsmp_imu.pipeline.check import compare_pair

    rng = np.random.default_rng(0)
    real = (_pair_windows(rng, 30), _pair_windows(rng, 30))  # the real pair: alike
    sharp = (_pair_windows(rng, 12, shift_q1=2.0), _pair_windows(rng, 12))
    found = compare_pair("waist", "sit_to_lie", "stand_to_lie", real, sharp, ("a", "b"))
    assert found.cue == "a q1" and found.synthetic_auc > 0.95 and abs(found.real_auc - 0.5) < 0.2
    assert len(found.flags) == 1 and "by a q1" in found.flags[0] and "hardly" in found.flags[0]
    # simulated windows as alike as the real ones: the pair is reported, not flagged
    alike = compare_pair("waist", "sit_to_lie", "stand_to_lie", real,
                         (_pair_windows(rng, 12), _pair_windows(rng, 12)), ("a", "b"))
    assert alike is not None and alike.flags == []


def test_a_cue_reversed_in_the_simulation_is_flagged_and_clear_pairs_are_skipped():
    from vsmp_imu.pipeline.check import MIN_PAIR_WINDOWS, compare_pair

    rng = np.random.default_rng(1)
    # the real first class reads a little higher on b (AUC about 0.7), the simulated one lower
    real = (_pair_windows(rng, 40, shift_mean=0.12), _pair_windows(rng, 40))
    syn = (_pair_windows(rng, 20, shift_mean=-0.12), _pair_windows(rng, 20))
    found = compare_pair("waist", "x", "y", real, syn, ("a", "b"))
    assert found.real_auc is not None
    assert any("the other way" in f and "b " in f for f in found.flags), found.flags
    # a real cue already separates the pair: nothing to learn wrongly there
    clear = (_pair_windows(rng, 30, shift_mean=1.0), _pair_windows(rng, 30))
    assert compare_pair("waist", "x", "y", clear, syn, ("a", "b")) is None
    # too few simulated windows say nothing
    few = (syn[0][: MIN_PAIR_WINDOWS - 1], syn[1])
    assert compare_pair("waist", "x", "y", real, few, ("a", "b")) is None


def test_pairs_are_checked_within_each_location():
    from vsmp_imu.pipeline.check import check_pairs

    rng = np.random.default_rng(2)
    w = {(label, place): (_pair_windows(rng, 20), _pair_windows(rng, 10, shift_q1=3.0 * (label == "x")))
         for place in ("wrist", "ankle") for label in ("x", "y")}
    found = check_pairs(w, {"wrist": ("a", "b"), "ankle": ("a", "b")})
    assert [(p.location, p.first, p.second) for p in found] == [("wrist", "x", "y"), ("ankle", "x", "y")]
    assert all(p.cue == "a q1" and p.flags for p in found)


def test_the_pair_check_needs_a_sample_in_every_quarter():
    from vsmp_imu.pipeline.check import QUARTERS, compare_pair, pairs_skipped

    assert pairs_skipped(QUARTERS) is None and "needs 4 samples" in pairs_skipped(QUARTERS - 1)
    rng = np.random.default_rng(3)
    real, syn = ((rng.normal(size=(20, QUARTERS, 2)), rng.normal(size=(20, QUARTERS, 2))) for _ in range(2))
    found = compare_pair("waist", "x", "y", real, syn, ("a", "b"))
    assert found is not None and np.isfinite([found.real_auc, found.synthetic_auc, found.real_best_separation]).all()


def test_flagged_pairs_are_plotted_and_none_means_no_plot(tmp_path):
    from vsmp_imu.pipeline.check import DataCheck, check_pairs

    rng = np.random.default_rng(3)
    check = DataCheck()
    check.windows_ = {(label, "wrist"): (_pair_windows(rng, 20), _pair_windows(rng, 10, shift_q1=3.0 * (label == "x")))
                      for label in ("x", "y")}
    check._channels = {"wrist": ("a", "b")}
    check.pairs_ = check_pairs(check.windows_, check._channels)
    path = check.plot_pairs(tmp_path / "pairs.png")
    assert path is not None and path.read_bytes()[:4] == b"\x89PNG"
    check.pairs_ = [p for p in check.pairs_ if not p.flags]
    assert check.plot_pairs(tmp_path / "none.png") is None and not (tmp_path / "none.png").exists()


def _executions(root, library, scale: float) -> object:
    """Two subjects, each standing up from sitting twice (each execution `scale` times as long as
    the library's file makes it), sitting between: per-sample labels, one run per execution."""
    backend = backend_for("procedural", ())
    rows = []
    for n, subject in enumerate(["a", "b"]):
        for k in range(2):
            for label, extra in (("sit_to_stand", {"duration_scale": scale}), ("sitting", {})):
                seed = 40 + 4 * n + 2 * k + (label == "sitting")
                motion = backend.generate(library.get(label).smp, seed, **extra)
                imu = ImuSimulator(50.0, seed=n).simulate(motion, "waist").data
                acc, gyr = imu[:, :3] @ P.T, imu[:, 3:] @ P.T
                rows.append(pd.DataFrame({"subject": subject, "label": label, "ax": acc[:, 0], "ay": acc[:, 1],
                                          "az": acc[:, 2], "gx": gyr[:, 0], "gy": gyr[:, 1], "gz": gyr[:, 2]}))
    (root / "data").mkdir(parents=True)
    pd.concat(rows).to_csv(root / "data" / "all.csv", index=False)
    spec = {"name": "my_phone", "data": "data", "fs_hz": 50, "class_min_share": {"sit_to_stand": 0.5},
            "locations": [{"name": "waist", "acc": ["ax", "ay", "az"], "gyr": ["gx", "gy", "gz"],
                           "acc_unit": "m/s^2", "gyr_unit": "rad/s", "axes": ["up", "left", "backward"]}]}
    (root / "dataset.yaml").write_text(yaml.safe_dump(spec))
    return root / "dataset.yaml"


def test_a_single_execution_faster_than_the_real_ones_is_flagged(cli, tmp_path):
    """People who stand up 1.8x as slowly as the library's file: its duration is flagged (the
    dominant frequency, which a single execution does not have, is not); at the file's own speed
    its duration is not."""
    library = ActivityLibrary.load()
    found = {}
    for scale in (1.0, 1.8):
        path = _executions(tmp_path / f"ds{scale}", library, scale)
        code, out, err = cli("data", "check", path, "--samples", "3", "-o", tmp_path / f"chk{scale}")
        assert code == 0, err
        written = json.loads((tmp_path / f"chk{scale}" / "check.json").read_text())
        found[scale] = {c["label"]: c for c in written["classes"]}
    same, slow = found[1.0]["sit_to_stand"], found[1.8]["sit_to_stand"]  # the file's speed, and 1.8x slower
    assert same["n_real_executions"] == slow["n_real_executions"] == 4
    assert abs(same["real_duration_s"] / same["synthetic_duration_s"] - 1) < 0.15
    assert not [f for f in same["flags"] if "execution" in f or "frequency" in f]
    assert 1.6 < slow["real_duration_s"] / slow["synthetic_duration_s"] < 2.0
    assert [f for f in slow["flags"] if "too fast" in f and "4 labelled executions" in f]
    # a continuous activity has no execution to time
    assert found[1.8]["sitting"]["n_real_executions"] is None and found[1.8]["sitting"]["real_duration_s"] is None


def test_movement_is_timed_from_the_rotation_rate_or_without_a_gyroscope_the_acceleration():
    from vsmp_imu.pipeline.check import MIN_EVENTS, Timing, duration_flag, movement_s, timing

    fs = 50.0
    t = np.arange(int(8 * fs)) / fs

    def bump(seconds):  # one rotation about one axis, rising and falling over `seconds`, mid-signal
        rate = np.where(np.abs(t - 4) < seconds / 2, np.cos(np.pi * (t - 4) / seconds) ** 2, 0.0)
        acc = np.c_[9.81 * np.cos(np.cumsum(rate) / fs), 9.81 * np.sin(np.cumsum(rate) / fs), 0 * t]
        return np.c_[acc, rate, 0 * t, 0 * t]

    short, long_ = movement_s(bump(1.5), fs), movement_s(bump(3.0), fs)
    assert 1.7 < long_ / short < 2.3 and short < 1.5
    assert movement_s(bump(3.0)[:, :3], fs) > movement_s(bump(1.5)[:, :3], fs)  # acceleration only
    assert movement_s(np.zeros((100, 6)), fs) is None
    few = timing([bump(3.0)] * (MIN_EVENTS - 1), [bump(1.5)], fs)  # too few real executions to say
    assert few.real_s is None and few.real_turns is None and few.synthetic_s == short
    enough = timing([bump(3.0)] * MIN_EVENTS, [bump(1.5)], fs)
    assert enough.real_s == long_ and enough.n_real == MIN_EVENTS
    # each bump turns by its integral: the longer one twice as far, about x only
    assert np.allclose(enough.real_turns[:, 0], 2 * enough.synthetic_turns[0, 0], rtol=0.02)
    assert np.allclose(enough.real_turns[:, 1:], 0)
    assert duration_flag(Timing(3.0, 2.0, 9)) and "too fast" in duration_flag(Timing(3.0, 2.0, 9))
    assert "too slow" in duration_flag(Timing(2.0, 3.0, 9))
    assert duration_flag(Timing(2.4, 2.0, 9)) is None and duration_flag(Timing(None, 2.0, 1)) is None


def test_an_execution_that_turns_much_faster_at_its_peak_than_the_real_ones_is_flagged():
    """The same turn in half the time turns twice as fast at its peak: flagged; a simulation that turns
    slower than the real executions is not (a real rate holds sway and noise a simulation lacks)."""
    from vsmp_imu.har.datasets.hapt import WAIST
    from vsmp_imu.pipeline.check import (
        MIN_EVENTS,
        Timing,
        compare,
        peak_turn_flag,
        peak_turn_rad_s,
        timing,
    )

    fs = 50.0
    t = np.arange(int(8 * fs)) / fs

    def turn(seconds, angle=1.5):  # `angle` rad about x, as a cos² rate over `seconds`, mid-signal
        rate = np.where(np.abs(t - 4) < seconds / 2, np.cos(np.pi * (t - 4) / seconds) ** 2, 0.0)
        rate *= angle / (rate.sum() / fs)
        return np.c_[np.full_like(t, 9.81), 0 * t, 0 * t, rate, 0 * t, 0 * t]

    slow, quick = peak_turn_rad_s(turn(3.0), fs), peak_turn_rad_s(turn(1.5), fs)
    assert 1.7 < quick / slow < 2.1
    assert peak_turn_rad_s(turn(3.0)[:, :3], fs) is None  # no gyroscope
    fast = timing([turn(3.0)] * MIN_EVENTS, [turn(1.5)] * 2, fs)
    assert fast.real_peak == pytest.approx(slow) and fast.synthetic_peak == pytest.approx(quick)
    assert f"turns the body {quick / slow:.1f}x as fast" in peak_turn_flag(fast)
    assert peak_turn_flag(timing([turn(1.5)] * MIN_EVENTS, [turn(3.0)], fs)) is None  # slower: not flagged
    assert peak_turn_flag(timing([turn(3.0)] * (MIN_EVENTS - 1), [turn(1.5)], fs)) is None  # too few to say
    windows = np.repeat(turn(3.0)[None, :100], 8, axis=0)
    checked = compare("x", WAIST, "x.json", windows, windows, fs, executions=fast)
    assert checked.synthetic_peak_turn_rad_s == round(quick, 3) and [f for f in checked.flags if "rad/s" in f]
    assert compare("x", WAIST, "x.json", windows, windows, fs, executions=Timing(3.0, 3.0, 5)).flags == []


def test_a_single_execution_is_timed_instead_of_read_for_a_rhythm():
    """Windows that peak at 1 Hz against windows at 3 Hz: a frequency flag for an activity with a
    rhythm, none for a single execution (compared by its duration instead)."""
    from vsmp_imu.har.datasets.hapt import WAIST
    from vsmp_imu.pipeline.check import Timing, compare

    t = np.arange(100) / 50.0

    def windows(hz):
        acc = np.c_[9.81 + 2 * np.sin(2 * np.pi * hz * t), 0 * t, 0 * t]
        return np.repeat(np.c_[acc, np.zeros((100, 3))][None], 8, axis=0)

    real, syn = windows(1.0), windows(3.0)
    rhythm = compare("x", WAIST, "x.json", real, syn, 50.0)
    single = compare("x", WAIST, "x.json", real, syn, 50.0, executions=Timing(3.0, 3.0, 5))
    assert [f for f in rhythm.flags if "dominant frequency" in f]
    assert single.flags == [] and single.real_duration_s == single.synthetic_duration_s == 3.0


def test_a_single_execution_is_judged_by_its_net_turn_not_by_where_windows_cut_it():
    """A movement that turns and turns back: windows that catch more of the first half read a
    net rate the real windows do not, the whole execution turns back to where it started on both
    sides. A single execution's turn flag compares the executions; a real turn the other way is
    still flagged."""
    from vsmp_imu.har.datasets.hapt import WAIST
    from vsmp_imu.pipeline.check import Timing, compare, turn_flag

    t = np.arange(100) / 50.0
    rest = np.c_[np.full(100, 9.81), np.zeros((100, 2))]
    real = np.repeat(np.c_[rest, np.zeros((100, 3))][None], 8, axis=0)
    syn = real.copy()
    syn[..., 3] = 0.6 * np.sin(np.pi * t / 2)  # each window catches only the turn out, not the turn back
    there_and_back = np.zeros((5, 3))
    windows = compare("x", WAIST, "x.json", real, syn, 50.0)
    single = compare("x", WAIST, "x.json", real, syn, 50.0,
                     executions=Timing(2.0, 2.0, 5, there_and_back, there_and_back[:2]))
    assert [f for f in windows.flags if "rotation rate" in f]
    assert single.flags == [] and single.real_execution_turn_deg == [0.0, 0.0, 0.0]
    quarter = np.array([0.0, 0.0, 90.0])
    assert turn_flag(quarter, quarter * 1.1, None, per="execution") is None
    assert "check the side" in turn_flag(quarter, -quarter, None, per="execution")
    assert "lacks" in turn_flag(quarter, 0 * quarter, None, per="execution")
    assert "one execution turns +90° about z" in turn_flag(quarter, 0 * quarter, None, per="execution")


def _level_windows(rng, n, level):
    """n windows (T=40, 2 channels) of noise around `level`."""
    return rng.normal(level, 0.3, (n, 40, 2))


def test_simulated_windows_taken_for_another_class_are_flagged_with_that_class():
    from vsmp_imu.pipeline.check import taken_flag, taken_for

    rng = np.random.default_rng(4)
    windows = {("x", "wrist"): (_level_windows(rng, 30, 0.0), _level_windows(rng, 10, 3.0)),  # reads like y
               ("y", "wrist"): (_level_windows(rng, 30, 3.0), _level_windows(rng, 10, 3.0)),
               ("z", "wrist"): (_level_windows(rng, 30, -3.0), np.zeros((0, 40, 2))),  # nothing simulated
               ("x", "ankle"): (_level_windows(rng, 30, 0.0), _level_windows(rng, 10, 0.0))}
    taken = taken_for(windows, "wrist")
    assert taken == {"x": {"y": 100.0}, "y": {"y": 100.0}}  # z is read by no one: it has no simulated window
    assert "takes 100 % of the simulated windows for y and 0 % for x" in taken_flag("x", taken["x"])
    assert taken_flag("y", taken["y"]) is None
    assert taken_for(windows, "ankle") == {}  # one class: nothing to take it for
    windows[("w", "wrist")] = (np.zeros((0, 40, 2)), _level_windows(rng, 10, 0.0))  # no real windows: not read
    assert "w" not in taken_for(windows, "wrist")


@pytest.mark.parametrize(("shares", "flagged"), [
    ({"x": 40.0, "y": 40.0, "z": 20.0}, False),  # a tie is no majority for the other class
    ({"y": 45.0, "x": 40.0, "z": 15.0}, True),
    ({"x": 100.0}, False),
    ({"y": 60.0, "z": 40.0}, True),  # never taken for itself
])
def test_the_taken_flag_needs_another_class_ahead_of_the_class_itself(shares, flagged):
    from vsmp_imu.pipeline.check import taken_flag

    flag = taken_flag("x", shares)
    assert (flag is not None) == flagged
    if flagged:
        assert f"for {next(iter(shares))} and {shares.get('x', 0.0):.0f} % for x" in flag


def test_the_taken_matrix_is_plotted_per_location_and_nothing_read_means_no_plot(tmp_path):
    from vsmp_imu.pipeline.check import ClassCheck, DataCheck, taken_matrix

    check = DataCheck()
    check.results_ = [ClassCheck("x", "wrist", "library", 3, 3, recognised_pct=20.0, taken_for={"y": 80.0, "x": 20.0}),
                      ClassCheck("y", "wrist", "library", 3, 3, recognised_pct=100.0, taken_for={"y": 100.0}),
                      ClassCheck("x", "ankle", "library", 3, 3, recognised_pct=100.0, taken_for={"x": 100.0})]
    path = check.plot_taken(tmp_path / "taken.png")
    assert path is not None and path.read_bytes()[:4] == b"\x89PNG"
    rows, columns, matrix = taken_matrix(check.results_, "wrist")
    assert rows == ["x", "y"] and columns == ["x", "y"] and matrix.tolist() == [[20.0, 80.0], [0.0, 100.0]]
    # a class read as one that has real windows but none simulated (no row of its own) still gets a column
    check.results_.append(ClassCheck("w", "wrist", "library", 3, 3, recognised_pct=0.0, taken_for={"z": 100.0}))
    rows, columns, matrix = taken_matrix(check.results_, "wrist")
    assert columns == ["x", "y", "w", "z"] and matrix.sum(axis=1).tolist() == [100.0, 100.0, 100.0]
    check.results_ = [ClassCheck("x", "wrist", "library", 3, 0)]
    assert check.plot_taken(tmp_path / "none.png") is None and not (tmp_path / "none.png").exists()


def test_the_table_fits_an_80_column_terminal_without_folding_a_long_label(tmp_path):
    import os
    import subprocess
    import sys

    path = _dataset(tmp_path / "ds", ActivityLibrary.load(), labels=("walking_downstairs", "sitting"))
    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}
    out = subprocess.run([sys.executable, "-c", "from vsmp_imu.cli import main; main()", "data", "check", str(path),
                          "--samples", "2", "-o", str(tmp_path / "chk")], env=env, capture_output=True, text=True,
                         check=True).stdout
    assert max(len(line) for line in out.splitlines()) <= 80
    header = next(line for line in out.splitlines() if line.split()[:2] == ["class", "real"])
    assert header.split()[-1] == "own"
    assert "walking_downstairs" in out.split()  # the 18-character label on one line


def test_the_forest_reads_at_most_a_capped_number_of_real_windows_per_class(monkeypatch):
    from vsmp_imu.har.backbones.rf import RandomForestECDF
    from vsmp_imu.pipeline import check

    seen = []
    fit = RandomForestECDF.fit
    monkeypatch.setattr(RandomForestECDF, "fit", lambda self, X, y, *a, **k: seen.append(np.bincount(y)) or
                        fit(self, X, y, *a, **k))
    monkeypatch.setattr(check, "TAKEN_MAX_PER_CLASS", 7)
    rng = np.random.default_rng(5)
    windows = {("x", "w"): (_level_windows(rng, 30, 0.0), _level_windows(rng, 4, 0.0)),
               ("y", "w"): (_level_windows(rng, 5, 3.0), _level_windows(rng, 4, 3.0))}
    assert check.taken_for(windows, "w") == {"x": {"x": 100.0}, "y": {"y": 100.0}}
    assert seen[0].tolist() == [7, 5]  # 30 drawn down to 7; 5 kept whole
    first_last = check._evenly(np.arange(30), 7)
    assert first_last[0] == 0 and first_last[-1] == 29 and len(set(first_last)) == 7
