"""ImuRecording files, plots and the `vsmp-imu imu` commands."""

from __future__ import annotations

import numpy as np
import pytest
from imu_motions import make_motion, walking

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.imu import CHANNELS, ImuRecording, ImuSimulator, read_imu_csv
from vsmp_imu.imu.plot import plot_imu

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def walk_motion():
    root, local = walking()
    return make_motion(4.0, root=root, local=local, activity="walking")


@pytest.fixture
def motion_file(tmp_path, walk_motion):
    return walk_motion.save(tmp_path / "walk.npz")


def test_csv_round_trip_keeps_data_rate_and_provenance(tmp_path, walk_motion):
    rec = ImuSimulator(50.0, seed=9).simulate(walk_motion, "right_wrist")
    path = rec.save_csv(tmp_path / "imu.csv")
    back = read_imu_csv(path)
    assert back.channel_names == CHANNELS
    assert back.fs_hz == 50.0 and back.start_s == pytest.approx(rec.start_s)
    np.testing.assert_allclose(back.data, rec.data, rtol=1e-9, atol=1e-12)
    assert back.meta["sensor"]["segment"] == "right_elbow"
    assert back.meta["motion"]["activity"] == "walking"
    assert back.meta["seed"] == 9
    assert path.read_text().splitlines()[3] == "time_s," + ",".join(CHANNELS)
    assert [p.name for p in tmp_path.iterdir()] == ["imu.csv"]  # no temp file left


def test_to_dataframe_has_time_index_and_channel_columns(walk_motion):
    rec = ImuSimulator(50.0, noise=False).simulate(walk_motion, "waist")
    df = rec.to_dataframe()
    assert list(df.columns) == list(CHANNELS)
    assert df.index.name == "time_s"
    assert df.index[1] - df.index[0] == pytest.approx(0.02)
    np.testing.assert_array_equal(df.to_numpy(), rec.data)


def test_plain_csv_without_header_comments_reads(tmp_path):
    path = tmp_path / "plain.csv"
    path.write_text("time_s,acc_x,acc_y\n0.00,1,2\n0.01,3,4\n0.02,5,6\n")
    rec = read_imu_csv(path)
    assert rec.fs_hz == pytest.approx(100.0) and rec.channel_names == ("acc_x", "acc_y")


@pytest.mark.parametrize("text, match", [
    ("acc_x,acc_y\n1,2\n", "time_s"),
    ("time_s,acc_x\n0.0,abc\n0.1,2\n", "non-numeric"),
    ("time_s,acc_x\n0.1,1\n0.0,2\n", "fs_hz"),
])
def test_bad_csv_raises_input_file_error(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputFileError, match=match):
        read_imu_csv(path)


@pytest.mark.parametrize("header, repeated", [
    ("time_s,acc_x,acc_y,acc_x", "'acc_x'"),  # pandas read the second as 'acc_x.1'
    ("time_s,acc_x,time_s,acc_y,acc_y", "'time_s', 'acc_y'"),
    ('time_s,"a,b",a,"a,b"', "'a,b'"),  # a quoted name with a comma is one name
])
def test_a_column_named_twice_is_refused_naming_the_file_and_the_column(tmp_path, header, repeated):
    path = tmp_path / "dup.csv"
    n = header.count(",")
    path.write_text("# fs_hz: 50\n" + header + "\n" + "".join(f"{t / 50}" + ",1" * n + "\n" for t in range(3)))
    with pytest.raises(InputFileError) as err:
        read_imu_csv(path)
    assert err.value.file == str(path)
    assert err.value.message == f"column(s) named more than once in the header: {repeated}"


def test_cli_plot_of_a_csv_with_a_column_named_twice_exits_2(cli, tmp_path):
    path = tmp_path / "dup.csv"
    path.write_text("time_s,acc_x,acc_y,acc_x\n0,1,2,3\n0.02,1,2,3\n0.04,1,2,3\n")
    code, _, err = cli("imu", "plot", path, "-o", tmp_path / "d.png")
    assert code == 2 and "dup.csv" in err and "named more than once in the header: 'acc_x'" in err, err
    assert not (tmp_path / "d.png").exists()


def test_recording_checks_its_shape():
    with pytest.raises(ValidationError, match="channel names"):
        ImuRecording(np.zeros((5, 6)), ("acc_x",), 50.0)
    with pytest.raises(ValidationError, match="fs_hz"):
        ImuRecording(np.zeros((5, 6)), CHANNELS, 0.0)


def test_plot_single_many_and_overlay(tmp_path, walk_motion):
    sim = ImuSimulator(50.0, seed=1)
    one = sim.simulate(walk_motion, "right_wrist")
    many = sim.simulate_many(walk_motion, ["waist", "right_wrist"])
    for name, data, kwargs in [
        ("one.png", one, {}),
        ("many.png", many, {}),
        ("overlay.png", [one, one.data * 1.1], {"labels": ["synthetic", "real"], "fs_hz": 50.0}),
        ("array.png", one.data[:, :3], {"channel_names": ["acc_x", "acc_y", "acc_z"], "fs_hz": 50.0}),
    ]:
        path = plot_imu(data, tmp_path / name, title=name, **kwargs)
        assert path.read_bytes()[:8] == PNG_MAGIC and path.stat().st_size > 10_000
    with pytest.raises(ValidationError, match="fs_hz"):
        plot_imu(one.data, tmp_path / "x.png")
    with pytest.raises(ValidationError, match="labels"):
        plot_imu([one, one], tmp_path / "x.png", labels=["only one"])


def test_cli_simulate_writes_csv_and_plot(cli, tmp_path, motion_file):
    out, png = tmp_path / "imu.csv", tmp_path / "imu.png"
    code, stdout, _ = cli("imu", "simulate", motion_file, "--location", "waist", "--fs", "50",
                          "--seed", "3", "-o", out, "--plot", png)
    assert code == 0, stdout
    rec = read_imu_csv(out)
    assert rec.channel_names == CHANNELS and rec.fs_hz == 50.0
    assert rec.meta["motion_file"] == str(motion_file)
    assert png.read_bytes()[:8] == PNG_MAGIC
    again = tmp_path / "again.csv"
    cli("imu", "simulate", motion_file, "--location", "waist", "--seed", "3", "-o", again)
    assert again.read_bytes() == out.read_bytes()


def test_cli_simulate_several_locations_without_noise(cli, tmp_path, motion_file):
    out = tmp_path / "imu.csv"
    code, stdout, _ = cli("imu", "simulate", motion_file, "--location", "waist,wrist", "--no-noise", "-o", out)
    assert code == 0, stdout
    rec = read_imu_csv(out)
    assert rec.locations == ("waist", "right_wrist")
    assert rec.meta["noise"] is False


def test_cli_unknown_location_exits_2_with_the_allowed_names(cli, tmp_path, motion_file):
    code, _, err = cli("imu", "simulate", motion_file, "--location", "kneecap", "-o", tmp_path / "x.csv")
    assert code == 2
    assert "kneecap" in err and "right_wrist" in err
    assert not (tmp_path / "x.csv").exists()


def test_cli_missing_motion_file_exits_2(cli, tmp_path):
    code, _, err = cli("imu", "simulate", tmp_path / "none.npz", "-o", tmp_path / "x.csv")
    assert code == 2 and "not found" in err


def test_cli_plot_overlays_files(cli, tmp_path, walk_motion):
    a = ImuSimulator(50.0, seed=1).simulate(walk_motion, "waist").save_csv(tmp_path / "a.csv")
    b = ImuSimulator(50.0, seed=2).simulate(walk_motion, "waist").save_csv(tmp_path / "b.csv")
    code, stdout, _ = cli("imu", "plot", a, b, "-o", tmp_path / "ab.png")
    assert code == 0, stdout
    assert (tmp_path / "ab.png").read_bytes()[:8] == PNG_MAGIC


def test_cli_locations_lists_placements_and_aliases(cli):
    code, stdout, _ = cli("imu", "locations")
    assert code == 0
    for word in ("waist", "right_wrist", "left_lower_leg", "right_elbow", "belt", "torso"):
        assert word in stdout
