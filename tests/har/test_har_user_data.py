"""A user's own data in the generic format: sides, limb words, accelerometer sign, warnings."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import yaml

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.align import axes_matrix as device_from_segment
from vsmp_imu.har.dataset import mirror_matrix, resolve_axes
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.imu import simulate_kinematics
from vsmp_imu.motion import Motion
from vsmp_imu.pipeline.sample import backend_for
from vsmp_imu.smp.library import ActivityLibrary

FS = 50.0
# one watch, crown toward the hand, on either wrist
WATCH_AXES = {"left": ["distal", "ulnar", "dorsal"], "right": ["distal", "radial", "dorsal"]}


def mirrored(motion: Motion) -> Motion:
    """The left-right mirror image of a motion (x = the body's left; joints swap sides)."""
    names = list(motion.joint_names)
    swap = [names.index(n.replace("left", "@").replace("right", "left").replace("@", "right"))
            for n in names]
    pos = motion.positions[:, swap] * np.array([-1.0, 1.0, 1.0])
    rot = motion.rotations[:, swap] * np.array([1.0, -1.0, -1.0, 1.0])
    return Motion(pos, rot, motion.fps, motion.joint_names, motion.parents, dict(motion.meta))


def _watch_readings(motion: Motion, side: str) -> np.ndarray:
    """(T, 6) acc (g, gravity included) and gyr (deg/s) of the watch on one wrist, device axes."""
    kin = simulate_kinematics(motion, f"{side}_wrist", FS)
    p = device_from_segment(resolve_axes(WATCH_AXES[side], f"{side}_wrist"))
    acc = kin.specific_force_seg() @ p.T / 9.80665
    gyr = np.degrees(kin.gyr_seg @ p.T)
    return np.hstack([acc, gyr])


def _table(readings: dict[str, np.ndarray]) -> pd.DataFrame:
    frames = []
    for side, x in readings.items():
        frames.append(pd.DataFrame({"subject": f"p_{side}", "label": "curl", "wrist": side,
                                    **{c: x[:, i] for i, c in enumerate(["ax", "ay", "az", "gx", "gy", "gz"])}}))
    return pd.concat(frames, ignore_index=True)


def _write(tmp_path, table: pd.DataFrame, **location) -> object:
    (tmp_path / "data").mkdir(exist_ok=True)
    table.to_csv(tmp_path / "data" / "watch.csv", index=False)
    loc = {"name": "right_wrist", "acc": ["ax", "ay", "az"], "gyr": ["gx", "gy", "gz"], "acc_unit": "g",
           "gyr_unit": "deg/s", **location}
    spec = {"name": "my_watch", "data": "data", "fs_hz": FS, "locations": [loc]}
    path = tmp_path / "dataset.yaml"
    path.write_text(yaml.safe_dump(spec, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def curl_motion() -> Motion:
    smp = ActivityLibrary.load().get("bicep_curls").smp
    return backend_for("procedural", ()).generate(smp, 3)


def test_same_motion_on_both_wrists_gives_matching_windows(tmp_path, curl_motion):
    """The right arm's curl and its mirror image done by the left arm, each recorded by the watch
    on that wrist, give the same windows once the left recording is mirrored by the loader."""
    readings = {"right": _watch_readings(curl_motion, "right"), "left": _watch_readings(mirrored(curl_motion), "left")}
    assert not np.allclose(readings["left"], readings["right"], atol=0.05)  # raw: different
    path = _write(tmp_path, _table(readings), axes=WATCH_AXES, side_column="wrist")
    win = load_dataset(path).windows(2.0, 0.5)
    right = win.X[win.subjects == "p_right"]
    left = win.X[win.subjects == "p_left"]
    assert len(right) == len(left) > 2
    np.testing.assert_allclose(left, right, atol=1e-3 * 9.81)
    # without the mirror (both declared as worn on the right) they do not match
    table = _table(readings).assign(wrist="right")
    plain = load_dataset(_write(tmp_path, table, axes=WATCH_AXES, side_column="wrist")).windows(2.0, 0.5)
    assert np.abs(plain.X[plain.subjects == "p_left"] - right).max() > 1.0


def test_right_recordings_are_untouched_and_mirror_is_an_involution():
    q = mirror_matrix(resolve_axes(WATCH_AXES["left"], "left_wrist"), resolve_axes(WATCH_AXES["right"], "right_wrist"))
    np.testing.assert_array_equal(q, np.diag([1.0, -1.0, 1.0]))  # the one acc axis that flips
    back = mirror_matrix(resolve_axes(WATCH_AXES["right"], "right_wrist"), resolve_axes(WATCH_AXES["left"], "left_wrist"))
    np.testing.assert_array_equal(back @ q, np.eye(3))


def test_limb_words_map_to_body_words():
    assert resolve_axes(["distal", "radial", "dorsal"], "right_wrist") == ("right", "forward", "up")
    assert resolve_axes(["distal", "ulnar", "dorsal"], "left_wrist") == ("left", "backward", "up")
    assert resolve_axes(["distal", "anterior", "medial"], "left_ankle") == ("down", "forward", "right")
    assert resolve_axes(["proximal", "anterior", "medial"], "right_thigh") == ("up", "forward", "left")
    with pytest.raises(ValidationError, match="left-handed"):
        resolve_axes(["distal", "radial", "dorsal"], "left_wrist")
    with pytest.raises(ValidationError, match="do not apply to the waist"):
        resolve_axes(["distal", "radial", "dorsal"], "waist")


def test_acc_sign_negates_the_accelerometer(tmp_path):
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "ax": np.full(200, -1.0), "ay": 0.0, "az": 0.0,
                         "gx": 0.0, "gy": 0.0, "gz": 0.0})
    up = load_dataset(_write(tmp_path, rows, axes=["distal", "radial", "dorsal"])).windows()
    down = load_dataset(_write(tmp_path, rows, axes=["distal", "radial", "dorsal"], acc_sign=-1)).windows()
    np.testing.assert_allclose(up.X[..., 0], -9.80665, rtol=1e-6)
    np.testing.assert_allclose(down.X[..., 0], 9.80665, rtol=1e-6)


@pytest.mark.parametrize(("location", "field"), [
    ({"axes": ["distal", "radial", "dorsal"], "side_column": "wrist"}, "locations[0].axes"),
    ({"axes": WATCH_AXES}, "locations[0].side_column"),
    ({"axes": {"left": WATCH_AXES["left"]}, "side_column": "wrist"}, "locations[0].axes"),
    ({"axes": {"left": WATCH_AXES["right"], "right": WATCH_AXES["right"]}, "side_column": "wrist"},
     "locations[0].axes.left"),
    ({"axes": ["distal", "radial", "dorsal"], "acc_sign": 2}, "locations[0].acc_sign"),
])
def test_side_and_axes_mistakes_name_file_and_field(tmp_path, location, field):
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "wrist": "left", "ax": np.ones(120), "ay": 0.0,
                         "az": 0.0, "gx": 0.0, "gy": 0.0, "gz": 0.0})
    path = _write(tmp_path, rows, **location)
    with pytest.raises(ValidationError) as err:
        load_dataset(path).windows()
    assert err.value.field == field and str(path) in err.value.render()


def test_a_side_value_other_than_left_or_right_is_refused(tmp_path):
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "wrist": "both", "ax": np.ones(120), "ay": 0.0,
                         "az": 0.0, "gx": 0.0, "gy": 0.0, "gz": 0.0})
    with pytest.raises(ValidationError) as err:
        load_dataset(_write(tmp_path, rows, axes=WATCH_AXES, side_column="wrist")).windows()
    assert err.value.field == "wrist" and "watch.csv" in err.value.render()


def test_warnings_for_undeclared_axes_and_a_wrong_unit(tmp_path):
    sitting = np.tile([0.0, 9.80665, 0.0], (200, 1))  # m/s^2 written into a file declared in g
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "ax": sitting[:, 0], "ay": sitting[:, 1],
                         "az": sitting[:, 2], "gx": 0.0, "gy": 0.0, "gz": 0.0})
    ds = load_dataset(_write(tmp_path, rows))
    assert len(ds.warnings) == 2
    assert "declares no axes" in ds.warnings[0] and "locations[0].axes" in ds.warnings[0]
    assert "class 'sit'" in ds.warnings[1] and "look like m/s²" in ds.warnings[1] and "96.2 m/s²" in ds.warnings[1]
    fine = load_dataset(_write(tmp_path, rows, axes=["distal", "radial", "dorsal"], acc_unit="m/s^2"))
    assert fine.warnings == []
    as_g = load_dataset(_write(tmp_path, rows.assign(ay=1.0), axes=["distal", "radial", "dorsal"],
                               acc_unit="m/s^2"))
    assert len(as_g.warnings) == 1 and "look like g" in as_g.warnings[0]


def test_labels_link_to_library_activities_under_any_dataset_name():
    """A dataset the library does not name (a renamed copy of HAPT, a user's watch) links its
    classes by activity name or alias; HAPT's own declared labels still link as before."""
    from vsmp_imu.pipeline.sources import LibrarySmpSource, entries_for

    lib = ActivityLibrary.load()
    found = entries_for("my_watch", ["walking", "Bicep curl", "hula"], lib)
    assert {k: v.name for k, v in found.items()} == {"walking": "walking", "Bicep curl": "bicep_curls"}
    assert entries_for("hapt", ["WALKING"], lib)["WALKING"].name == "walking"
    smps = LibrarySmpSource(lib).smps("my_renamed_copy", ["walking", "sitting"])
    assert [s[0][0] for s in smps.values()] == ["library:walking", "library:sitting"]


def test_an_unlinked_class_says_how_to_link_it():
    from vsmp_imu.errors import ConfigError
    from vsmp_imu.pipeline.sources import LibrarySmpSource

    with pytest.raises(ConfigError) as err:
        LibrarySmpSource(ActivityLibrary.load()).smps("my_watch", ["walking", "hula"])
    text = err.value.render()
    assert "hula" in text and "datasets: {my_watch: <class>}" in text and "--source smp:DIR" in text


def test_evaluate_and_generate_refuse_an_unlinked_class_before_any_work(cli, tmp_path):
    rows = pd.DataFrame({"subject": np.repeat(["p1", "p2"], 200), "label": "hula", "ax": 1.0, "ay": 0.0,
                         "az": 0.0, "gx": 0.0, "gy": 0.0, "gz": 0.0})
    path = _write(tmp_path, rows, axes=["distal", "radial", "dorsal"])
    for args in (("evaluate", "--dataset", path, "--methods", "real,vsmp", "-o", tmp_path / "ev"),
                 ("generate", "--dataset", path, "--holdout", "p1", "-o", tmp_path / "gen")):
        code, _, err = cli(*args)
        assert code == 2 and str(path) in err and "'labels'" in err and "hula" in err and "--source smp:DIR" in err
    assert not (tmp_path / "ev" / "records").exists()


def test_dataset_info_prints_the_warnings(cli, tmp_path):
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "ax": 0.0, "ay": np.full(200, 9.81), "az": 0.0,
                         "gx": 0.0, "gy": 0.0, "gz": 0.0})
    code, out, err = cli("dataset", "info", _write(tmp_path, rows), "--json")
    assert code == 0 and "warning:" in err and "declares no axes" in err
    import json

    assert len(json.loads(out)["warnings"]) == 2


def test_two_sides_in_one_recording_are_refused(tmp_path):
    rows = pd.DataFrame({"subject": "p1", "label": "sit", "wrist": np.repeat(["left", "right"], 60),
                         "ax": 1.0, "ay": 0.0, "az": 0.0, "gx": 0.0, "gy": 0.0, "gz": 0.0})
    with pytest.raises(ValidationError) as err:
        load_dataset(_write(tmp_path, rows, axes=WATCH_AXES, side_column="wrist")).windows()
    assert err.value.field == "wrist" and "session_column" in err.value.render()
