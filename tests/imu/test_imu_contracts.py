"""Exact contracts of the virtual sensor: input checks and the fields they name, the noise
model by its formulas, the reading composition acc = M (a + g grav) + b + k n, the output
clock and the spline's half-amplitude cutoff (a property, not the implementation)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu import SegmentKinematics, VirtualSensor, draw_noise, sensor_readings
from vsmp_imu.imu.channels import CHANNELS, prefixed, split_channel
from vsmp_imu.imu.kinematics import check_settings, output_times
from vsmp_imu.imu.readings import reading_features, reading_weights
from vsmp_imu.imu.recording import ImuRecording
from vsmp_imu.imu.sensor import ACC_BIAS_WALK, ACC_NOISE_DENSITY, GYR_BIAS_WALK, GYR_NOISE_DENSITY
from vsmp_imu.imu.spline import MIN_PENALTY, penalty_for_cutoff
from vsmp_imu.seeding import rng_for


# -- channels -------------------------------------------------------------------------------
def test_channel_names_split_and_join():
    assert CHANNELS == ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
    assert prefixed("right_wrist")[0] == "right_wrist_acc_x" and len(prefixed("a")) == 6
    assert prefixed("a", ("gyr_z",)) == ("a_gyr_z",)
    assert split_channel("right_wrist_gyr_y") == ("right_wrist", "gyr_y")
    assert split_channel("acc_x") == ("", "acc_x")
    assert split_channel("temperature") == ("", "temperature")
    assert split_channel("xacc_x") == ("", "xacc_x")


# -- the sensor and its noise -----------------------------------------------------------------
def test_sensor_defaults_and_noise_std_formulas():
    s = VirtualSensor.at("waist")
    assert s.name == "waist" and s.location == "waist" and s.acc_bias == (0.0, 0.0, 0.0)
    assert pytest.approx(300e-6 * 9.80665) == ACC_NOISE_DENSITY and pytest.approx(np.deg2rad(0.01)) == GYR_NOISE_DENSITY
    assert (ACC_BIAS_WALK, GYR_BIAS_WALK) == (1e-3, 1e-4)
    std = s.noise_std(25.0)
    assert std == pytest.approx({"acc_white": ACC_NOISE_DENSITY * 5, "gyr_white": GYR_NOISE_DENSITY * 5,
                                 "acc_walk": 1e-3 / 5, "gyr_walk": 1e-4 / 5})
    assert VirtualSensor.at("waist", name="belt").location == "belt"


@pytest.mark.parametrize(("field", "value"), [
    ("attachment_m", (0.0, 1.0)), ("attachment_m", (0.0, np.nan, 0.0)),
    ("acc_bias", (1.0, 2.0)), ("gyr_bias", (np.inf, 0.0, 0.0)),
    ("mounting_xyzw", (0.0, 0.0, 0.0, 0.0)), ("mounting_xyzw", (0.0, 0.0, 1.0)),
    ("acc_noise_density", -1.0), ("gyr_noise_density", np.inf), ("acc_bias_walk", np.nan),
    ("gyr_bias_walk", -1e-9),
])
def test_sensor_rejects_bad_fields_by_name(field, value):
    with pytest.raises(ValidationError) as err:
        VirtualSensor.at("waist", **{field: value})
    assert err.value.field == field


def test_sensor_normalizes_the_quaternion_and_keeps_zero_noise():
    s = VirtualSensor.at("waist", mounting_xyzw=(0.0, 0.0, 0.0, 2.0), acc_noise_density=0.0,
                         attachment_m=[0.1, 0.2, 0.3])
    assert s.mounting_xyzw == (0.0, 0.0, 0.0, 1.0) and s.acc_noise_density == 0.0
    assert s.attachment_m == (0.1, 0.2, 0.3)
    assert np.allclose(s.mounting_matrix(), np.eye(3))
    theta = s.theta()
    assert theta["attachment_m"] == [0.1, 0.2, 0.3] and theta["mounting_xyzw"] == [0.0, 0.0, 0.0, 1.0]
    assert theta["acc_noise_density_m_s2_per_sqrt_hz"] == 0.0 and theta["location"] == "waist"
    assert s.theta(attachment_m=np.array([1, 2, 3]))["attachment_m"] == [1.0, 2.0, 3.0]


def test_noise_draws_come_from_the_named_stream_and_compose_white_plus_walk():
    s = VirtualSensor.at("waist")
    noise = draw_noise(s, 50, 100.0, 7, "sim", 2)
    raw = rng_for(7, "imu_noise", "sim", 2).standard_normal((4, 50, 3))
    std = s.noise_std(100.0)
    assert noise.n_samples == 50 and noise.std == std
    assert np.array_equal(noise.acc_white, raw[0]) and np.array_equal(noise.gyr_walk, raw[3])
    assert np.allclose(noise.acc, std["acc_white"] * raw[0] + std["acc_walk"] * np.cumsum(raw[2], 0))
    assert np.allclose(noise.gyr, std["gyr_white"] * raw[1] + std["gyr_walk"] * np.cumsum(raw[3], 0))


# -- readings ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def kin():
    rng = np.random.default_rng(3)
    t = 40
    grav = Rotation.random(t, random_state=4).apply([0.0, 9.81, 0.0])
    return SegmentKinematics(np.arange(t) / 50.0, 50.0, rng.normal(size=(t, 3)), grav,
                             rng.normal(size=(t, 3)), "waist", "pelvis", (0.0, 0.0, 0.0))


def test_readings_are_mounting_times_segment_signals_plus_bias_plus_scaled_noise(kin):
    noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples, 50.0, 1, "k")
    m = Rotation.from_euler("zxy", [[10, 20, 30], [-40, 5, 60]], degrees=True).as_matrix()
    b_a, b_w = np.array([[0.1, 0.2, 0.3], [-0.1, 0.0, 0.4]]), np.array([[0.01, 0.0, 0.0], [0.0, 0.02, 0.03]])
    out = sensor_readings(kin, m, b_a, b_w, np.array([1.5, 0.5]), np.array([2.0, 0.7]),
                          np.array([True, False]), noise)
    assert out.shape == (2, kin.n_samples, 6)
    for n, grav in enumerate((1.0, 0.0)):
        acc = (kin.acc_lin_seg + grav * kin.grav_seg) @ m[n].T + b_a[n] + [1.5, 0.5][n] * noise.acc
        gyr = kin.gyr_seg @ m[n].T + b_w[n] + [2.0, 0.7][n] * noise.gyr
        assert np.allclose(out[n, :, :3], acc) and np.allclose(out[n, :, 3:], gyr)
    exact = sensor_readings(kin)
    assert exact.shape == (1, kin.n_samples, 6)
    assert np.allclose(exact[0], np.concatenate([kin.specific_force_seg(), kin.gyr_seg], axis=1))
    rot = sensor_readings(kin, Rotation.from_matrix(m[0]))[0]
    assert np.allclose(rot[:, :3], kin.specific_force_seg() @ m[0].T)


def test_reading_features_and_weights_layout(kin):
    f = reading_features(kin)
    assert f.shape == (kin.n_samples, 10) and (f[:, 9] == 1.0).all()
    assert np.array_equal(f[:, 3:6], kin.grav_seg)
    w = reading_weights(with_noise=False)
    assert w.shape == (1, 10, 6)
    noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples - 1, 50.0, 1)
    with pytest.raises(ValidationError) as err:
        reading_features(kin, noise)
    assert err.value.field == "noise"


@pytest.mark.parametrize(("kwargs", "field"), [
    ({"mounting": np.eye(2)}, "mounting"), ({"acc_bias": np.zeros((2, 2))}, "acc_bias"),
    ({"gyr_bias": [1.0]}, "gyr_bias"), ({"acc_noise_scale": np.zeros((2, 2))}, "acc_noise_scale"),
    ({"gyr_noise_scale": []}, "gyr_noise_scale"),
    ({"acc_bias": np.zeros((2, 3)), "gyr_bias": np.zeros((3, 3))}, "candidates"),
])
def test_reading_weights_reject_bad_shapes_by_name(kwargs, field):
    with pytest.raises(ValidationError) as err:
        reading_weights(**kwargs)
    assert err.value.field == field


def test_candidate_counts_broadcast_from_one():
    w = reading_weights(acc_bias=np.zeros((4, 3)), gravity_included=np.array([True, False, True, False]))
    assert w.shape == (4, 16, 6)
    assert (w[1, 3:6, 0:3] == 0).all() and np.array_equal(w[0, 3:6, 0:3], np.eye(3))


# -- the output clock and settings --------------------------------------------------------------
def test_output_times_stay_inside_the_trimmed_span():
    t = output_times(2.0, 10.0, 0.25)
    assert np.allclose(t, 0.25 + np.arange(16) / 10.0)
    assert output_times(1.0, 4.0, 0.0).tolist() == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert output_times(0.5, 4.0, 0.25).tolist() == [0.25]
    with pytest.raises(ValidationError) as err:
        output_times(0.4, 10.0, 0.25)
    assert err.value.field == "trim_s"


@pytest.mark.parametrize(("args", "field"), [
    ((0.0, None, 0.0), "fs_hz"), ((np.inf, None, 0.0), "fs_hz"), ((50.0, 0.0, 0.0), "smoothing_hz"),
    ((50.0, np.nan, 0.0), "smoothing_hz"), ((50.0, None, -0.1), "trim_s"), ((50.0, None, np.inf), "trim_s"),
])
def test_settings_are_checked_by_name(args, field):
    with pytest.raises(ValidationError) as err:
        check_settings(*args)
    assert err.value.field == field
    check_settings(50.0, 8.0, 0.0)
    check_settings(50.0, None, 0.5)


# -- spline cutoff ---------------------------------------------------------------------------------
@pytest.mark.parametrize(("cutoff", "fps"), [(8.0, 30.0), (2.0, 30.0), (12.0, 60.0)])
def test_spline_penalty_puts_half_amplitude_at_the_cutoff(cutoff, fps):
    lam = penalty_for_cutoff(cutoff, fps)
    w = 2 * np.pi * cutoff / fps
    b = (66 + 52 * np.cos(w) + 2 * np.cos(2 * w)) / 120
    assert 1.0 / (1.0 + lam * (2 * np.sin(w / 2)) ** 6 / b**2) == pytest.approx(0.5, rel=1e-9)


def test_spline_penalty_interpolates_without_a_cutoff_below_nyquist():
    assert penalty_for_cutoff(None, 30.0) == MIN_PENALTY == 1e-8
    assert penalty_for_cutoff(15.0, 30.0) == MIN_PENALTY
    assert penalty_for_cutoff(14.9, 30.0) > MIN_PENALTY


# -- recordings ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(("kwargs", "field"), [
    ({"data": np.zeros(6)}, "data"), ({"channel_names": ("a",) * 6}, "channel_names"),
    ({"channel_names": ("a", "b")}, "channel_names"), ({"fs_hz": 0.0}, "fs_hz"), ({"fs_hz": np.nan}, "fs_hz"),
])
def test_recording_checks_name_the_field(kwargs, field):
    args = {"data": np.zeros((4, 6)), "channel_names": CHANNELS, "fs_hz": 50.0} | kwargs
    with pytest.raises(ValidationError) as err:
        ImuRecording(**args)
    assert err.value.field == field


def _two_locations() -> ImuRecording:
    names = prefixed("left_wrist") + prefixed("waist")
    data = np.arange(3 * 12, dtype=float).reshape(3, 12)
    return ImuRecording(data, names, 50.0, {"k": 1}, start_s=2.0)


def test_recording_views_by_location_and_name():
    rec = _two_locations()
    assert rec.locations == ("left_wrist", "waist")
    waist = rec.at_location("waist")
    assert waist.channel_names == CHANNELS and np.array_equal(waist.data, rec.data[:, 6:])
    assert (waist.fs_hz, waist.start_s, waist.meta) == (50.0, 2.0, {"k": 1})
    assert waist.meta is not rec.meta
    assert np.array_equal(rec.channels(["waist_gyr_z", "left_wrist_acc_x"]), rec.data[:, [11, 0]])
    assert rec.duration_s == 3 / 50 and np.allclose(rec.times, 2.0 + np.arange(3) / 50)
    with pytest.raises(ValidationError) as err:
        rec.at_location("chest")
    assert err.value.field == "location" and err.value.allowed == "left_wrist, waist"
    assert err.value.message == "no channels for location 'chest'"
    with pytest.raises(ValidationError) as err:
        rec.channels(["waist_acc_x", "nope", "nada"])
    assert err.value.message == "no channel(s) nope, nada" and err.value.field == "channels"
    assert err.value.allowed == ", ".join(rec.channel_names)


def test_recording_csv_round_trip_keeps_rate_start_and_meta(tmp_path):
    rec = _two_locations()
    back = ImuRecording.read_csv(rec.save_csv(tmp_path / "r.csv"))
    assert back.channel_names == rec.channel_names and np.allclose(back.data, rec.data)
    assert (back.fs_hz, back.start_s, back.meta) == (50.0, 2.0, {"k": 1})
    text = rec.to_csv_text().splitlines()
    assert text[1] == "# fs_hz: 50" and text[2] == '# meta: {"k": 1}'
    no_rate = "\n".join([text[0]] + text[3:]) + "\n"
    (tmp_path / "n.csv").write_text(no_rate)
    assert ImuRecording.read_csv(tmp_path / "n.csv").fs_hz == pytest.approx(50.0)


def test_recording_csv_errors_name_the_file_and_the_line(tmp_path):
    from vsmp_imu.errors import InputFileError

    long_bad = "# fs_hz: fast" + "x" * 80
    cases = {
        "header.csv": (long_bad + "\ntime_s,acc_x\n0,1\n", f"bad header line '{long_bad[:60]}' ("),
        "nothing.csv": ("# fs_hz: 50\n# meta: {}\n", "not a readable CSV ("),
        "notime.csv": ("t,acc_x\n0,1\n", "no 'time_s' column"),
    }
    for name, (text, start) in cases.items():
        path = tmp_path / name
        path.write_text(text)
        with pytest.raises(InputFileError) as err:
            ImuRecording.read_csv(path)
        assert err.value.message.startswith(start) and err.value.file == str(path)
    assert err.value.allowed == "a header 'time_s,<channels...>'"  # the last case


def test_aliases_of_a_placement():
    from vsmp_imu.imu.placement import aliases_of

    assert aliases_of("left_wrist") == ("non_dominant_wrist", "left_hand", "left_forearm")
    assert aliases_of("chest") == ("torso",)


def test_csv_text_writes_sorted_meta_and_fixed_number_formats():
    rec = ImuRecording(np.array([[1.0 / 3, 2e-7, 5.0, 6.0, 7.0, 8.0]]), CHANNELS, 50.0,
                       {"b": 1, "a": np.float32(0.5)}, start_s=0.25)
    lines = rec.to_csv_text().splitlines()
    assert lines[2] == '# meta: {"a": "0.5", "b": 1}'  # keys sorted, non-JSON values as text
    assert lines[3] == "time_s," + ",".join(CHANNELS)
    assert lines[4] == "0.250000,0.3333333333,2e-07,5,6,7,8"


def test_simulate_many_places_each_sensor_side_by_side():
    from imu_motions import make_motion, walking

    from vsmp_imu.imu import ImuSimulator

    root, local = walking()
    motion = make_motion(3.0, 30.0, root, local)
    sim = ImuSimulator(50.0, seed=3, trim_s=0.3)
    many = sim.simulate_many(motion, ["waist", "left_wrist"])
    one = sim.simulate(motion, "left_wrist")
    assert many.channel_names == prefixed("waist") + prefixed("left_wrist")
    assert np.array_equal(many.data[:, 6:], one.data)
    assert many.start_s == one.start_s == pytest.approx(0.3)
    meta = many.meta
    assert meta["kind"] == "imu_recording" and meta["locations"] == ["waist", "left_wrist"]
    assert meta["sensors"]["left_wrist"] == one.meta["sensor"] and meta["sensors"]["left_wrist"]["attachment_m"]
    for sensors, message in (([], "need at least one sensor location"),
                             (["waist", "waist"], "duplicate sensor locations in waist, waist")):
        with pytest.raises(ValidationError) as err:
            sim.simulate_many(motion, sensors)
        assert err.value.field == "location" and err.value.message == message
    with pytest.raises(ValidationError) as err:
        ImuSimulator(50.0, smoothing_hz=-1.0).simulate_many(motion, ["waist"])
    assert err.value.field == "smoothing_hz"
    # the settings are checked before any sensor is looked up
    with pytest.raises(ValidationError) as err:
        ImuSimulator(50.0, smoothing_hz=-1.0).simulate_many(motion, ["no_such_place"])
    assert err.value.field == "smoothing_hz"
    assert many.meta["motion"] == motion.meta == one.meta["motion"]


@pytest.mark.parametrize(("text", "message"), [
    ("time_s,acc_x\n", "no channels or no rows"),
    ("time_s\n0\n0.02\n", "no channels or no rows"),
    ("time_s,acc_x\n0,1\n0.02,abc\n", "non-numeric values ("),
    ("time_s,acc_x\n0,1\nlater,2\n", "non-numeric values ("),
    ("time_s,acc_x\n0,1\n0.02,nan\n0.04,inf\n", "NaN or inf values in 2 row(s), the first at data row 2"),
    ("time_s,acc_x\n0,1\nnan,2\n", "NaN or inf values in 1 row(s), the first at data row 2"),
    ("time_s,acc_x\n0,1\n0,2\n", "cannot infer fs_hz: time_s must increase (or give '# fs_hz:')"),
    ("time_s,acc_x\n0,1\n", "cannot infer fs_hz: time_s must increase (or give '# fs_hz:')"),
    ("# fs_hz: -5\ntime_s,acc_x\n0,1\n", "fs_hz must be positive, got -5.0"),
])
def test_recording_csv_content_errors(tmp_path, text, message):
    from vsmp_imu.errors import InputFileError

    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputFileError) as err:
        ImuRecording.read_csv(path)
    assert err.value.message.startswith(message) and err.value.file == str(path)


def test_header_lines_parse_with_or_without_a_space_after_the_hash(tmp_path):
    path = tmp_path / "tight.csv"
    path.write_text('#fs_hz: 20\n#meta: {"k": 2}\ntime_s,acc_x\n0,1\n0.05,2\n')
    rec = ImuRecording.read_csv(path)
    assert (rec.fs_hz, rec.meta) == (20.0, {"k": 2})


def test_a_single_row_with_a_declared_rate_is_a_recording(tmp_path):
    path = tmp_path / "one.csv"
    path.write_text("# fs_hz: 20\ntime_s,acc_x\n1.5,2\n")
    rec = ImuRecording.read_csv(path)
    assert (rec.n_samples, rec.fs_hz, rec.start_s) == (1, 20.0, 1.5) and rec.data.tolist() == [[2.0]]


@pytest.mark.parametrize("with_noise", [True, False])
def test_channel_weights_are_the_nonzero_part_of_the_dense_weights(with_noise):
    from vsmp_imu.imu.readings import channel_weights, fill_weights

    rng = np.random.default_rng(4)
    n = 5
    args = (Rotation.random(n, random_state=1).as_matrix(), rng.normal(size=(n, 3)), rng.normal(size=(n, 3)),
            rng.uniform(0.5, 2, n), rng.uniform(0.5, 2, n), np.array([True, False, True, True, False]))
    dense = fill_weights(*args, with_noise)
    cols, features = channel_weights(*args, with_noise)
    assert cols.shape == (6, n, features.shape[1])
    rebuilt = np.zeros_like(dense)
    for c in range(6):
        assert len(set(features[c])) == features.shape[1]  # no feature twice: padding never overwrites
        rebuilt[:, features[c], c] = cols[c]
    assert np.array_equal(rebuilt, dense)  # every nonzero weight is in a channel's columns
