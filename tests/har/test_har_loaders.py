"""Dataset loaders on small fixtures in each published file format, and the generic format."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError, InputFileError, ValidationError
from vsmp_imu.har.dataset import SensorLocation, check_axes
from vsmp_imu.har.datasets import dataset_names, load_dataset
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as STANDARD_GRAVITY


def test_registry_lists_names_and_refuses_unknown(tmp_path):
    assert {"hapt", "hapt12", "mmfit", "utd-mhad", "mmact", "pamap2", "had-aw"} <= set(
        dataset_names()
    )
    with pytest.raises(ConfigError) as err:
        load_dataset("nope")
    assert "hapt12" in err.value.render() and ".yaml" in err.value.render()
    with pytest.raises(ConfigError, match="--data-dir"):
        load_dataset("pamap2")
    with pytest.raises(InputFileError, match="no PAMAP2 files"):
        load_dataset("pamap2", tmp_path)


def test_pamap2(fixtures_dir):
    ds = load_dataset("pamap2", fixtures_dir / "pamap2")
    assert ds.subjects == ["101", "102"] and ds.info.fs_hz == 100.0
    assert len(ds.info.label_names) == 18 and ds.info.label_names[4] == "running"
    assert [loc.name for loc in ds.info.locations] == ["right_wrist", "chest", "right_ankle"]
    assert len(ds.info.channel_names) == 18 and ds.info.channel_names[6] == "chest_acc_x"
    rec = ds.recordings()[0]
    assert np.isfinite(rec.data).all()  # dropped packets interpolated
    assert rec.data[:, 0].mean() == pytest.approx(9.81, abs=0.1)  # m/s², unchanged
    assert rec.data[:, 4].mean() == pytest.approx(0.25)  # gyro y in rad/s
    assert (rec.labels[200:300] == -1).all()  # activity 0 = transient, unlabelled
    w = ds.windows()
    assert w.class_counts()[3] == 2 and w.class_counts()[4] == 2  # walking, running
    only = ds.get_subset(["102"])
    assert only.subjects == ["102"] and len(only.windows()) == 2 and len(ds.windows()) == 4
    with pytest.raises(ValidationError, match="unknown subject"):
        ds.get_subset(["999"])
    with_hr = type(ds)(fixtures_dir / "pamap2", parts=("chest",), include_heart_rate=True)
    assert with_hr.info.channel_names[-1] == "heart_rate"
    assert np.isfinite(with_hr.recordings()[0].data).all()


def test_pamap2_long_gap_splits_recording(tmp_path, fixtures_dir):
    from vsmp_imu.har.datasets.pamap2 import PAMAP2

    src = fixtures_dir / "pamap2" / "Protocol" / "subject101.dat"
    lines = src.read_text().splitlines()
    for i in range(100, 250):  # 1.5 s without the hand IMU
        cols = lines[i].split()
        cols[4:7] = ["NaN"] * 3
        lines[i] = " ".join(cols)
    (tmp_path / "Protocol").mkdir()
    (tmp_path / "Protocol" / "subject101.dat").write_text("\n".join(lines) + "\n")
    recs = PAMAP2(tmp_path).recordings()
    assert [r.n_samples for r in recs] == [100, 250]


def test_utd_mhad(fixtures_dir):
    ds = load_dataset("utd-mhad", fixtures_dir / "utd_mhad")
    assert ds.subjects == ["1", "2"] and len(ds.info.label_names) == 27
    rec = next(r for r in ds.recordings() if r.recording_id == "a1_s1_t1")
    assert rec.data[:, 2].mean() == pytest.approx(STANDARD_GRAVITY)  # 1 g -> m/s²
    assert rec.data[:, 3].mean() == pytest.approx(math.pi / 2)  # 90 deg/s -> rad/s
    assert ds.info.location_by_label["right_arm_swipe_left"] == "right_wrist"
    assert ds.info.location_by_label["jogging_in_place"] == "right_thigh"
    w = ds.windows()
    short = w[w.meta["recording"] == "a24_s1_t1"]  # 80 samples < 100: padded to one window
    assert len(short) == 1 and np.allclose(short.X[0, 80:], short.X[0, 79])
    assert w.label_names[short.y[0]] == "sit_to_stand"


def test_mmfit(fixtures_dir):
    ds = load_dataset("mmfit", fixtures_dir / "mmfit")
    assert ds.subjects == ["2", "3"]  # w00 -> participant 2, w12 -> participant 3
    assert ds.skipped == ["w16: missing w16_eb_l_acc.npy, w16_eb_l_gyr.npy"]
    assert [loc.name for loc in ds.info.locations] == [
        "left_wrist",
        "right_wrist",
        "right_thigh",
        "head",
    ]
    rec = ds.recordings()[0]
    assert rec.data.shape[1] == 24
    assert rec.data[:, 1].mean() == pytest.approx(9.81)  # every device resampled to 100 Hz
    assert np.diff(rec.labels[rec.labels >= 0]).max() == 4  # squats (0) then pushups (4)
    w = ds.windows()
    assert w.class_counts().tolist()[:5] == [2, 0, 0, 0, 4]


def test_mmact(fixtures_dir):
    ds = load_dataset("mmact", fixtures_dir / "mmact")
    assert ds.info.label_names == ("sitting_down", "walking")  # 'Walking.csv' merged
    assert ds.info.channel_names[:6] == (
        "right_thigh_acc_x",
        "right_thigh_acc_y",
        "right_thigh_acc_z",
        "right_thigh_gyr_x",
        "right_thigh_gyr_y",
        "right_thigh_gyr_z",
    )
    assert ds.info.channel_names[6:] == (
        "right_wrist_acc_x",
        "right_wrist_acc_y",
        "right_wrist_acc_z",
    )
    assert ds.index["session"].tolist()[0] == "scene1_session1"
    rec = ds.recordings()[1]
    assert rec.n_samples == 150  # 3 s at 50 Hz
    assert rec.data[:, 0].mean() == pytest.approx(9.81, abs=0.05)
    w = ds.windows()
    assert len(w) == 6 and w.unique_subjects() == ["1", "2"]


def test_had_aw(fixtures_dir):
    ds = load_dataset("had-aw", fixtures_dir / "had_aw")
    assert ds.info.label_names == ("eating", "typing")
    rec = ds.recordings()[0]
    # CoreMotion's -1 g on the axis pointing up becomes +9.8 m/s²
    assert rec.data[:, 0].mean() == pytest.approx(STANDARD_GRAVITY, abs=0.05)
    assert rec.data[:, 3].mean() == pytest.approx(0.1)
    assert ds.index["activity"].tolist() == ["eating", "typing", "typing"] * 2


def test_generic_format(fixtures_dir):
    ds = load_dataset(fixtures_dir / "generic" / "dataset.yaml")
    assert ds.info.name == "my_waist_phone" and ds.info.fs_hz == 50.0
    assert ds.info.label_names == ("walk", "sit")
    loc = ds.info.locations[0]
    assert loc.axes == ("up", "left", "backward") and loc.acc_unit == "g"
    assert ds.info.channel_names == ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
    rec = ds.recordings()[0]
    assert rec.data[:, 0].mean() == pytest.approx(STANDARD_GRAVITY, abs=0.3)
    w = ds.windows()
    assert w.class_counts().tolist() == [9, 6] and w.unique_subjects() == ["p1", "p2", "p3"]


def _generic_copy(tmp_path, fixtures_dir):
    target = tmp_path / "g"
    shutil.copytree(fixtures_dir / "generic", target)
    return target


def test_generic_errors_name_file_and_column(tmp_path, fixtures_dir):
    root = _generic_copy(tmp_path, fixtures_dir)
    yaml_path = root / "dataset.yaml"
    csv = root / "data" / "p2.csv"
    lines = csv.read_text().splitlines()
    lines[5] = lines[5].replace(lines[5].split(",")[4], "nan", 1)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValidationError) as err:
        load_dataset(yaml_path)
    text = err.value.render()
    assert "p2.csv" in text and "field 'ay'" in text and "data row 5" in text

    lines[5] = lines[5].replace("nan", "inf")
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValidationError, match="inf"):
        load_dataset(yaml_path)

    csv.write_text("\n".join(line.rsplit(",", 1)[0] for line in lines) + "\n")  # drop gz
    with pytest.raises(ValidationError) as err:
        load_dataset(yaml_path)
    assert "p2.csv" in err.value.render() and "'gz'" in err.value.render()


def test_generic_yaml_errors(tmp_path, fixtures_dir):
    root = _generic_copy(tmp_path, fixtures_dir)
    yaml_path = root / "dataset.yaml"
    text = yaml_path.read_text()
    yaml_path.write_text(text.replace("name: waist", "name: belly"))
    with pytest.raises(ValidationError) as err:
        load_dataset(yaml_path)
    assert "dataset.yaml" in err.value.render() and "locations[0].name" in err.value.render()
    yaml_path.write_text(text.replace("axes: [up, left, backward]", "axes: [up, left, forward]"))
    with pytest.raises(ValidationError, match="left-handed"):
        load_dataset(yaml_path)
    yaml_path.write_text(text.replace("labels: [walk, sit]", "labels: [walk]"))
    with pytest.raises(ValidationError, match="sit are not declared"):
        load_dataset(yaml_path)
    yaml_path.write_text(text + "  - [unclosed\n")
    with pytest.raises(ValidationError, match="not valid YAML"):
        load_dataset(yaml_path)
    yaml_path.write_text(text.replace("fs_hz: 50 ", "").replace("time_column: t", ""))
    with pytest.raises(ValidationError, match="fs_hz, a time_column"):
        load_dataset(yaml_path)


def test_generic_rate_estimated_from_time_column(tmp_path, fixtures_dir):
    root = _generic_copy(tmp_path, fixtures_dir)
    yaml_path = root / "dataset.yaml"
    yaml_path.write_text(yaml_path.read_text().replace("fs_hz: 50 ", "# no rate "))
    assert load_dataset(yaml_path).info.fs_hz == 50.0


def test_generic_single_parquet_table(tmp_path, fixtures_dir):
    import pandas as pd

    root = _generic_copy(tmp_path, fixtures_dir)
    table = pd.concat([pd.read_csv(p) for p in sorted((root / "data").glob("*.csv"))])
    table.to_parquet(root / "all.parquet")
    yaml_path = root / "dataset.yaml"
    yaml_path.write_text(yaml_path.read_text().replace("data: data ", "data: all.parquet "))
    ds = load_dataset(yaml_path)
    assert ds.subjects == ["p1", "p2", "p3"] and len(ds.windows()) == 15


def test_axis_conventions_are_checked():
    assert check_axes(["up", "forward", "left"]) == ("up", "forward", "left")
    with pytest.raises(ValidationError, match="not three different"):
        check_axes(["up", "down", "left"])
    with pytest.raises(ValidationError, match="unknown axis word"):
        check_axes(["up", "north", "left"])
    with pytest.raises(ValidationError, match="unknown sensor location"):
        SensorLocation("pocket", ("acc_x",), None, True, "g", None)


def test_a_damaged_time_column_is_refused_before_resampling():
    """A timestamp far off the others (found by the generic-dataset fuzz test) would ask the common
    grid for billions of samples: refused with the file named, like any damaged input."""
    from vsmp_imu.errors import InputFileError
    from vsmp_imu.har.datasets.resample import MAX_UPSAMPLING, common_grid

    t = np.arange(100) / 50.0
    values = np.ones((100, 3))
    grid, data = common_grid([(t, values), (t, values)], 100.0, "rec.csv")
    assert len(grid) == 199 and data.shape == (199, 6)
    far = t.copy()
    far[-1] = 1e9
    with pytest.raises(InputFileError, match="timestamps span") as err:
        common_grid([(far, values)], 100.0, "rec.csv")
    assert "rec.csv" in err.value.render()
    slow = np.arange(100) * (MAX_UPSAMPLING / 100.0)  # 1 reading per MAX_UPSAMPLING grid samples: allowed
    assert len(common_grid([(slow, values)], 100.0, "rec.csv")[0]) == 99 * MAX_UPSAMPLING + 1
