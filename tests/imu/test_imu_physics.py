"""Physics tests of the virtual IMU (IMUSim style): known motions, known readings."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from imu_motions import (
    constant,
    fk_at,
    make_motion,
    smooth_random,
    spin,
    standing,
    walking,
)
from scipy.signal import welch
from scipy.spatial.transform import Rotation, RotationSpline

from vsmp_imu.imu import (
    PLACEMENTS,
    ImuSimulator,
    VirtualSensor,
    sensor_readings,
    simulate_kinematics,
)
from vsmp_imu.motion.skeleton import SMPL22_JOINTS
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G

EXACT = ImuSimulator(50.0, noise=False)
AT_PELVIS = VirtualSensor.at("waist", attachment_m=(0.0, 0.0, 0.0))

unit_axes = st.tuples(*[st.floats(-1, 1) for _ in range(3)]).filter(lambda v: np.linalg.norm(v) > 0.2)


# -- static bodies ---------------------------------------------------------------


def test_static_upright_body_reads_gravity_only_at_every_placement():
    motion = make_motion(3.0)
    for name in PLACEMENTS:
        rec = EXACT.simulate(motion, name)
        acc, gyr = rec.data[:, :3], rec.data[:, 3:]
        np.testing.assert_allclose(np.linalg.norm(acc, axis=1), G, atol=1e-6, err_msg=name)
        np.testing.assert_allclose(gyr, 0.0, atol=1e-9, err_msg=name)
        # T-pose: every segment frame is (x=left, y=up, z=forward), so up = +y reads +g_n
        np.testing.assert_allclose(acc, np.tile([0.0, G, 0.0], (len(acc), 1)), atol=1e-6, err_msg=name)


def test_lying_on_the_back_reads_gravity_on_the_forward_axis():
    supine = Rotation.from_euler("x", -90, degrees=True)  # body's forward (+z) turned to world up
    motion = make_motion(3.0, local={"pelvis": constant(supine)})
    for name in ("waist", "chest", "right_thigh"):
        acc = EXACT.simulate(motion, name).data[:, :3]
        np.testing.assert_allclose(acc, np.tile([0.0, 0.0, G], (len(acc), 1)), atol=1e-6, err_msg=name)


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000))
def test_any_static_pose_reads_rotated_gravity(seed):
    rots = Rotation.random(3, random_state=seed)
    local = {"pelvis": constant(rots[0]), "right_shoulder": constant(rots[1]), "left_hip": constant(rots[2])}
    motion = make_motion(2.0, local=local)
    for name in ("waist", "right_upper_arm", "right_wrist", "left_thigh"):
        rec = EXACT.simulate(motion, name)
        seg = Rotation.from_quat(motion.rotations[0, motion.joint_index(PLACEMENTS[name].segment)])
        expected = seg.apply([0.0, G, 0.0], inverse=True)
        np.testing.assert_allclose(rec.data[:, :3], np.tile(expected, (rec.n_samples, 1)), atol=1e-6)
        np.testing.assert_allclose(rec.data[:, 3:], 0.0, atol=1e-9)


# -- rotations ---------------------------------------------------------------------


@settings(max_examples=10, deadline=None)
@given(unit_axes, st.floats(0.3, 6.0), st.integers(0, 1000))
def test_constant_rotation_gives_constant_gyro_in_the_sensor_frame(axis, rate, seed):
    axis = np.asarray(axis) / np.linalg.norm(axis)
    offset = Rotation.random(random_state=seed)
    motion = make_motion(3.0, local={"pelvis": spin(axis, rate, offset)})
    gyr = EXACT.simulate(motion, AT_PELVIS).data[:, 3:]
    # R(t) = exp(rate t axis) offset  =>  body rate = offset^T axis rate
    expected = offset.apply(axis * rate, inverse=True)
    np.testing.assert_allclose(gyr, np.tile(expected, (len(gyr), 1)), atol=1e-6 * max(rate, 1.0))


@pytest.mark.parametrize("axis", [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0)])
def test_constant_rotation_with_tilted_mounting(axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    rate = 2.0
    mount = Rotation.from_euler("xyz", [20, -35, 50], degrees=True)
    motion = make_motion(3.0, local={"pelvis": spin(axis, rate)})
    sensor = AT_PELVIS.with_(mounting_xyzw=tuple(mount.as_quat()))
    gyr = EXACT.simulate(motion, sensor).data[:, 3:]
    np.testing.assert_allclose(gyr, np.tile(mount.apply(axis * rate), (len(gyr), 1)), atol=1e-6)
    assert not np.allclose(gyr[0], axis * rate, atol=0.1)  # the mounting did act


def test_bent_forearm_spinning_with_the_body_reads_the_rate_in_forearm_axes():
    rate = 1.5
    bend = Rotation.from_euler("yz", [70, 30], degrees=True)
    motion = make_motion(3.0, local={"pelvis": spin([0, 1, 0], rate), "right_elbow": constant(bend)})
    gyr = EXACT.simulate(motion, "right_wrist").data[:, 3:]
    expected = bend.apply([0.0, rate, 0.0], inverse=True)
    np.testing.assert_allclose(gyr, np.tile(expected, (len(gyr), 1)), atol=1e-6)


def test_rotation_spline_rate_is_in_the_body_frame():
    times = np.arange(61) / 30
    rots = Rotation.from_rotvec(np.stack([np.sin(times), 0.5 * np.cos(1.3 * times), 0.3 * times], 1))
    spline = RotationSpline(times, rots)
    t, h = np.linspace(0.3, 1.7, 15), 1e-6
    body = (spline(t).inv() * spline(t + h)).as_rotvec() / h
    world = (spline(t + h) * spline(t).inv()).as_rotvec() / h
    rate = spline(t, 1)
    np.testing.assert_allclose(rate, body, atol=1e-4)
    assert np.abs(rate - world).max() > 0.1


def test_spinning_body_lever_arm_gives_centripetal_acceleration_at_the_sensor():
    rate = 3.0
    motion = make_motion(3.0, local={"pelvis": spin([0, 1, 0], rate)})
    sensor = VirtualSensor.at("waist", attachment_m=(0.0, 0.0, 0.15))  # 15 cm in front of the axis
    acc = EXACT.simulate(motion, sensor).data[:, :3]
    expected = [0.0, G, -rate**2 * 0.15]  # toward the axis = backward in the body frame
    np.testing.assert_allclose(acc, np.tile(expected, (len(acc), 1)), atol=2e-3)


# -- translations ------------------------------------------------------------------


def test_uniform_circular_motion_reads_centripetal_acceleration_toward_the_centre():
    r, omega = 1.5, 2.0

    def circle(t):
        out = standing(t)
        out[:, 0] += r * np.cos(omega * t)
        out[:, 2] += r * np.sin(omega * t)
        return out

    motion = make_motion(4.0, root=circle)
    rec = EXACT.simulate(motion, AT_PELVIS)
    t = rec.times
    toward_centre = -np.stack([np.cos(omega * t), np.zeros_like(t), np.sin(omega * t)], 1)
    v = omega * r
    expected = v**2 / r * toward_centre + [0.0, G, 0.0]
    np.testing.assert_allclose(rec.data[:, :3], expected, atol=2e-3 * v**2 / r)
    np.testing.assert_allclose(rec.data[:, 3:], 0.0, atol=1e-9)


def test_carousel_facing_the_direction_of_travel_reads_the_centre_on_its_right():
    r, omega = 2.0, 1.5

    def circle(t):
        out = standing(t)
        out[:, 0] += r * np.cos(omega * t)
        out[:, 2] += r * np.sin(omega * t)
        return out

    motion = make_motion(4.0, root=circle, local={"pelvis": spin([0, 1, 0], -omega)})
    rec = EXACT.simulate(motion, AT_PELVIS)
    v = omega * r
    expected = np.tile([-(v**2) / r, G, 0.0], (rec.n_samples, 1))  # x = left, so the right is -x
    np.testing.assert_allclose(rec.data[:, :3], expected, atol=2e-3 * v**2 / r)
    np.testing.assert_allclose(rec.data[:, 3:], np.tile([0.0, -omega, 0.0], (rec.n_samples, 1)), atol=1e-6)


# -- splines vs finite differences -------------------------------------------------


def _finite_difference_truth(root, local, times, segment, attach, h=1e-3):
    """Sensor-point acceleration and body rate (segment frame) by central differences."""
    j = SMPL22_JOINTS.index(segment)
    pos, rot = [], []
    for dt in (-h, 0.0, h):
        p, q = fk_at(times + dt, root, local)
        r = Rotation.from_quat(q[:, j])
        pos.append(p[:, j] + r.apply(attach))
        rot.append(r)
    acc_world = (pos[0] - 2 * pos[1] + pos[2]) / h**2
    acc_seg = rot[1].apply(acc_world, inverse=True)
    gyr_seg = (rot[0].inv() * rot[2]).as_rotvec() / (2 * h)
    return acc_seg, gyr_seg


@settings(max_examples=6, deadline=None)
@given(st.integers(0, 10_000), st.sampled_from(["waist", "right_wrist", "left_thigh", "head"]))
def test_spline_derivatives_match_finite_differences_on_smooth_trajectories(seed, location):
    root, local = smooth_random(seed)
    motion = make_motion(5.0, root=root, local=local)
    kin = simulate_kinematics(motion, location, 50.0)
    acc_fd, gyr_fd = _finite_difference_truth(root, local, kin.times, kin.segment, np.asarray(kin.attachment_m))
    acc_scale = np.abs(acc_fd).max() + 0.1
    gyr_scale = np.abs(gyr_fd).max() + 0.1
    assert np.abs(kin.acc_lin_seg - acc_fd).max() < 0.02 * acc_scale
    assert np.abs(kin.gyr_seg - gyr_fd).max() < 0.02 * gyr_scale


def test_frame_jitter_is_suppressed_by_the_smoothing_spline():
    root, local = walking()
    clean = make_motion(6.0, root=root, local=local)
    jitter = np.random.default_rng(3).normal(0.0, 1e-3, clean.positions.shape)  # 1 mm per frame
    noisy = make_motion(6.0, root=root, local=local)
    noisy.positions = noisy.positions + jitter
    truth = simulate_kinematics(clean, "waist", 50.0).acc_lin_seg
    smoothed = simulate_kinematics(noisy, "waist", 50.0).acc_lin_seg
    raw = simulate_kinematics(noisy, "waist", 50.0, smoothing_hz=None).acc_lin_seg
    err_smooth = np.sqrt(np.mean((smoothed - truth) ** 2))
    err_raw = np.sqrt(np.mean((raw - truth) ** 2))
    assert err_smooth < 0.35 * err_raw


def _band_energy(x: np.ndarray, fs: float, lo: float, hi: float) -> float:
    f, psd = welch(x, fs=fs, nperseg=128, axis=0)
    return float(psd[(f >= lo) & (f <= hi)].sum())


def test_orientation_noise_of_a_recorded_trajectory_stays_out_of_the_gyroscope():
    # a foot recorded at 100 fps (motion capture) with 0.5 deg of frame-to-frame orientation noise
    fps, location = 100.0, "right_foot"
    root, local = walking()
    clean = make_motion(8.0, fps=fps, root=root, local=local)
    noisy = make_motion(8.0, fps=fps, root=root, local=local)
    j = SMPL22_JOINTS.index(PLACEMENTS[location].segment)
    jitter = Rotation.from_rotvec(np.random.default_rng(0).normal(0.0, np.deg2rad(0.5), (noisy.n_frames, 3)))
    noisy.rotations[:, j] = (Rotation.from_quat(noisy.rotations[:, j]) * jitter).as_quat()
    rec = ImuSimulator(fps, noise=False).simulate(noisy, location)
    assert rec.meta["smoothing_hz"] == "placement"
    k = np.round(rec.times * fps).astype(int)  # output samples fall on frames
    frames = Rotation.from_quat(noisy.rotations[:, j])
    central = (frames[k - 1].inv() * frames[k + 1]).as_rotvec() * fps / 2  # body rate
    exact = RotationSpline(noisy.times, frames)(rec.times, 1)  # exact interpolation of the noise
    gyr = rec.data[:, 3:]
    band = {name: _band_energy(x, fps, 25.0, 50.0) for name, x in
            (("simulator", gyr), ("central", central), ("exact", exact))}
    assert band["simulator"] <= band["central"] < band["exact"], band
    truth = ImuSimulator(fps, noise=False).simulate(clean, location).data[:, 3:]
    rms = {name: float(np.sqrt(np.mean((x - truth) ** 2))) for name, x in
           (("simulator", gyr), ("central", central))}
    assert rms["simulator"] < 0.5 * rms["central"], rms


def test_the_spline_cutoff_follows_the_placement():
    root, local = walking()
    motion = make_motion(4.0, root=root, local=local)
    assert PLACEMENTS["right_foot"].smoothing_hz > PLACEMENTS["waist"].smoothing_hz
    for location in ("waist", "right_foot"):
        kin = simulate_kinematics(motion, location, 50.0)
        assert kin.meta["smoothing_hz"] == PLACEMENTS[location].smoothing_hz
        same = simulate_kinematics(motion, location, 50.0, smoothing_hz=PLACEMENTS[location].smoothing_hz)
        np.testing.assert_array_equal(kin.gyr_seg, same.gyr_seg)
    assert simulate_kinematics(motion, "right_foot", 50.0, smoothing_hz=4.0).meta["smoothing_hz"] == 4.0


# -- mounting, resampling, pipeline -------------------------------------------------


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 10_000))
def test_mounting_rotates_acc_and_gyro_consistently(seed):
    root, local = smooth_random(seed)
    kin = simulate_kinematics(make_motion(3.0, root=root, local=local), "right_wrist", 50.0)
    mount = Rotation.random(random_state=seed)
    plain = sensor_readings(kin)[0]
    mounted = sensor_readings(kin, mount.as_matrix())[0]
    np.testing.assert_allclose(mounted[:, :3], mount.apply(plain[:, :3]), atol=1e-9)
    np.testing.assert_allclose(mounted[:, 3:], mount.apply(plain[:, 3:]), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(mounted[:, :3], axis=1), np.linalg.norm(plain[:, :3], axis=1))
    # the angle between the acc and gyro vectors is a physical quantity: mounting keeps it
    np.testing.assert_allclose(np.sum(mounted[:, :3] * mounted[:, 3:], 1), np.sum(plain[:, :3] * plain[:, 3:], 1),
                               atol=1e-9)


def test_resampling_30fps_to_50hz_gives_the_analytic_derivatives():
    amp, f_pos = 0.2, 0.8
    ang, f_rot = 0.6, 0.6
    w_pos, w_rot = 2 * np.pi * f_pos, 2 * np.pi * f_rot

    def sway(t):
        out = standing(t)
        out[:, 0] += amp * np.sin(w_pos * t)
        return out

    def turn(t):
        return Rotation.from_rotvec(np.outer(ang * np.sin(w_rot * t), [0.0, 1.0, 0.0]))

    acc_rec = EXACT.simulate(make_motion(6.0, fps=30.0, root=sway), AT_PELVIS)
    gyr_rec = EXACT.simulate(make_motion(6.0, fps=30.0, local={"pelvis": turn}), AT_PELVIS)
    t = acc_rec.times
    assert acc_rec.fs_hz == 50.0 and np.allclose(np.diff(t), 1 / 50)
    assert not np.allclose(t * 30, np.round(t * 30))  # most samples fall between frames
    np.testing.assert_allclose(acc_rec.data[:, 0], -amp * w_pos**2 * np.sin(w_pos * t), atol=2e-3 * amp * w_pos**2)
    np.testing.assert_allclose(gyr_rec.data[:, 4], ang * w_rot * np.cos(w_rot * t), atol=2e-3 * ang * w_rot)


def test_walking_pipeline_30fps_to_50hz_is_finite_without_edge_spikes():
    root, local = walking(cadence_hz=1.0)
    motion = make_motion(6.0, fps=30.0, root=root, local=local)
    sim = ImuSimulator(50.0, noise=False)
    for name in ("waist", "right_wrist", "left_thigh", "right_ankle"):
        rec = sim.simulate(motion, name)
        assert np.isfinite(rec.data).all()
        assert rec.times[0] == pytest.approx(0.2) and rec.times[-1] == pytest.approx(5.8)
        n_edge = int(0.5 * rec.fs_hz)
        middle = np.abs(rec.data[n_edge:-n_edge]).max(0)
        edges = np.abs(np.vstack([rec.data[:n_edge], rec.data[-n_edge:]])).max(0)
        # the gait is periodic: the edges must look like the rest of the recording
        assert np.all(edges <= 1.05 * middle + 1e-3), (name, edges, middle)
        # no spline edge effect survives the trim: the edge samples are as exact as the rest
        kin = simulate_kinematics(motion, name, 50.0)
        acc_fd, gyr_fd = _finite_difference_truth(root, local, kin.times, kin.segment, np.asarray(kin.attachment_m))
        assert np.abs(kin.acc_lin_seg - acc_fd).max() < 2.5e-3 * np.abs(acc_fd).max()
        assert np.abs(kin.gyr_seg - gyr_fd).max() < 2.5e-3 * np.abs(gyr_fd).max()
