"""What L_sim is made of: each term, its weight, and the windows it is scored on.

Paper, appendix "Simulation-in-the-Loop Optimization":
L_sim = 1.0 ||S(X) - S(D)||_F + 0.5 ||PSD(X) - PSD(D)||_2 + 0.5 ||r(X) - r(D)||_2,
2 s windows. Every expected value here is written from the definition (numpy on
explicit slices), never with the function under test, and targets are built
from a real-window D_stat split the way pipeline/fold.py builds them.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding import stats
from vsmp_imu.grounding.align import Convention, axes_matrix
from vsmp_imu.grounding.calibrate import ETA_NOMINAL, SimInTheLoopCalibrator, eta_rotation
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.grounding.stats import (
    LinearMoments,
    StatSummary,
    TargetStatistics,
    segment,
    sim_loss,
    summarize_sequence,
    summarize_windows,
)
from vsmp_imu.har.windows import window_geometry, window_starts
from vsmp_imu.imu import VirtualSensor, draw_noise, sensor_readings, simulate_kinematics

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_rank_align_stats import _direct_stats  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "imu"))
from imu_motions import make_motion, walking  # noqa: E402

FS = 50.0


def _summary(cov, psd, norms, acf) -> StatSummary:
    return StatSummary(np.asarray(cov, float), np.asarray(psd, float), np.asarray(norms, float),
                       np.asarray(acf, float))


def _target() -> StatSummary:
    """A hand-made target: unit covariance, all energy in band 0, norms (10, 1, 2, 0.5), acf 0.5."""
    psd = np.zeros((6, 6))
    psd[:, 0] = 1.0
    return _summary(np.eye(6), psd, [10.0, 1.0, 2.0, 0.5], np.full((6, 6), 0.5))


def _replace(s: StatSummary, **changes) -> StatSummary:
    fields = {"cov": s.cov, "psd": s.psd, "norms": s.norms, "acf": s.acf} | changes
    return _summary(**fields)


# -- the appendix constants ----------------------------------------------------------------
def test_weights_windows_bands_and_lags_are_the_appendix_values():
    assert (stats.LAMBDA_COV, stats.LAMBDA_PSD, stats.LAMBDA_R) == (1.0, 0.5, 0.5)
    assert stats.COV_WINDOW_S == 2.0
    assert stats.PSD_BAND_EDGES_HZ == (0.0, 0.5, 1.0, 2.0, 4.0, 8.0)
    assert stats.ACF_LAGS == (1, 2, 5, 10, 20, 50)
    assert list(stats.band_edges(50.0)) == [0.0, 0.5, 1.0, 2.0, 4.0, 8.0, 25.0]


# -- each term alone, with its weight --------------------------------------------------------
def test_covariance_term_is_relative_frobenius_with_weight_one():
    t = _target()
    cand = _replace(t, cov=2.0 * np.eye(6))  # ||I||_F / ||I||_F = 1
    assert sim_loss(cand, t) == pytest.approx(1.0, rel=1e-9)
    off = np.eye(6)
    off[0, 1] = off[1, 0] = 3.0  # error ||.||_F = sqrt(18), target norm sqrt(6)
    assert sim_loss(_replace(t, cov=off), t) == pytest.approx(np.sqrt(18) / np.sqrt(6), rel=1e-9)


def test_psd_term_is_the_l2_band_distance_with_weight_half():
    t = _target()
    psd = np.zeros((6, 6))
    psd[:, 1] = 1.0  # every channel moves its energy from band 0 to band 1: 6 * 2 squared units
    assert sim_loss(_replace(t, psd=psd), t) == pytest.approx(0.5 * np.sqrt(12.0), rel=1e-9)
    one = t.psd.copy()
    one[2] = [0.5, 0.0, 0.0, 0.0, 0.0, 0.5]  # one channel, one band pair
    assert sim_loss(_replace(t, psd=one), t) == pytest.approx(0.5 * np.sqrt(0.5), rel=1e-9)


@pytest.mark.parametrize(
    ("index", "scale"),
    [(0, 10.0), (1, 10.0), (2, 2.0), (3, 2.0)],  # acc norms relative to RMS |a|, gyr to RMS |w|
)
def test_norm_terms_are_relative_to_the_target_rms_norms(index, scale):
    t = _target()
    norms = t.norms.copy()
    norms[index] += 1.0
    assert sim_loss(_replace(t, norms=norms), t) == pytest.approx(0.5 * 1.0 / (scale + 1e-3), rel=1e-9)


def test_acf_term_has_weight_half_and_shares_one_l2_norm_with_the_norms():
    t = _target()
    acf = t.acf.copy()
    acf[4, 5] += 0.3
    acf[0, 0] -= 0.4
    assert sim_loss(_replace(t, acf=acf), t) == pytest.approx(0.5 * 0.5, rel=1e-9)
    norms = t.norms + np.array([0.0, 0.0, 2.0 * (2.0 + 1e-3), 0.0])  # relative error 2 on RMS |w|
    both = _replace(t, acf=acf, norms=norms)
    assert sim_loss(both, t) == pytest.approx(0.5 * np.hypot(0.5, 2.0), rel=1e-9)  # not 0.5 * (0.5 + 2)


def test_the_three_terms_add_up():
    t = _target()
    psd = np.zeros((6, 6))
    psd[:, 1] = 1.0
    acf = t.acf.copy()
    acf[0, 0] += 0.6
    cand = _summary(2.0 * np.eye(6), psd, t.norms, acf)
    assert sim_loss(cand, t) == pytest.approx(1.0 + 0.5 * np.sqrt(12.0) + 0.5 * 0.6, rel=1e-9)


def test_sim_loss_scores_each_candidate_of_a_batch_on_its_own():
    t = _target()
    psd = np.zeros((6, 6))
    psd[:, 1] = 1.0
    batch = _summary(np.stack([np.eye(6), 2 * np.eye(6), np.eye(6)]), np.stack([t.psd, t.psd, psd]),
                     np.stack([t.norms] * 3), np.stack([t.acf] * 3))
    got = sim_loss(batch, t)
    assert got.shape == (3,)
    assert got == pytest.approx([0.0, 1.0, 0.5 * np.sqrt(12.0)], abs=1e-9)


# -- signal pairs that differ in one statistic -------------------------------------------------
@pytest.fixture(scope="module")
def signal():
    """Six channels of distinct coloured noise with a gravity-like offset, 8 windows of 2 s."""
    rng = np.random.default_rng(5)
    x = np.cumsum(rng.normal(0, 1, (800, 6)), axis=0) * 0.05 + rng.normal(0, 0.3, (800, 6))
    x[:, 0] = x[:, 0] + 0.5 * x[:, 1]  # cross-channel structure
    x[:, 1] += 9.81
    return x


def _rel_cov(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_a_sign_flip_changes_only_the_covariance_term(signal):
    flipped = signal * np.array([1, -1, 1, 1, 1, 1])
    a, b = summarize_sequence(signal, FS), summarize_sequence(flipped, FS)
    assert np.allclose(a.psd, b.psd) and np.allclose(a.norms, b.norms) and np.allclose(a.acf, b.acf)
    assert not np.allclose(a.cov, b.cov)
    assert sim_loss(b, a) == pytest.approx(_rel_cov(b.cov, a.cov), rel=1e-9)


def test_a_gyro_gain_changes_covariance_and_gyro_norms_only(signal):
    louder = signal * np.array([1, 1, 1, 2, 2, 2])
    a, b = summarize_sequence(signal, FS), summarize_sequence(louder, FS)
    assert np.allclose(a.psd, b.psd) and np.allclose(a.acf, b.acf)
    assert np.allclose(a.norms[:2], b.norms[:2]) and np.allclose(b.norms[2:], 2 * a.norms[2:])
    scale = np.array([a.norms[2], a.norms[2]]) + 1e-3
    r = np.linalg.norm((b.norms[2:] - a.norms[2:]) / scale)
    assert sim_loss(b, a) == pytest.approx(_rel_cov(b.cov, a.cov) + 0.5 * r, rel=1e-9)


def test_a_tone_moved_to_another_band_changes_psd_and_acf_but_not_covariance():
    t = np.arange(800) / FS
    low = np.stack([np.sin(2 * np.pi * 3.0 * t + k) for k in range(6)], axis=1)  # band (2, 4]
    high = np.stack([np.sin(2 * np.pi * 6.0 * t + k) for k in range(6)], axis=1)  # band (4, 8]
    a, b = summarize_sequence(low, FS), summarize_sequence(high, FS)
    assert np.allclose(np.diag(a.cov), np.diag(b.cov))  # same power per channel
    assert np.allclose(a.norms, b.norms)
    assert (a.psd.argmax(-1) == 3).all() and (b.psd.argmax(-1) == 4).all()
    psd = np.linalg.norm(b.psd - a.psd)
    acf = np.linalg.norm(b.acf - a.acf)
    norms = np.linalg.norm((b.norms - a.norms) / (a.norms[[0, 0, 2, 2]] + 1e-3))
    expect = _rel_cov(b.cov, a.cov) + 0.5 * psd + 0.5 * np.hypot(norms, acf)
    assert sim_loss(b, a) == pytest.approx(expect, rel=1e-9)
    assert psd > 1.0 and acf > 0.5  # both terms carry real weight here


# -- windowing by content ----------------------------------------------------------------------
def _ramp(n: int, channels: int = 6) -> np.ndarray:
    return np.arange(n * channels, dtype=float).reshape(n, channels)


def test_segment_cuts_consecutive_slices_and_drops_the_tail():
    x = _ramp(250)
    w = segment(x, 100)
    assert w.shape == (2, 100, 6)
    assert np.array_equal(w[0], x[0:100]) and np.array_equal(w[1], x[100:200])
    batch = np.stack([x, -x])
    wb = segment(batch, 100)
    assert np.array_equal(wb[1, 1], -x[100:200])
    short = _ramp(40)
    assert np.array_equal(segment(short, 100)[0], short)
    exact = _ramp(200)
    assert np.array_equal(segment(exact, 100), exact.reshape(2, 100, 6))
    assert np.array_equal(segment(exact, 200)[0], exact)


@pytest.mark.parametrize("fs", [50.0, 25.0, 20.5])
def test_candidate_windows_are_the_2s_slices_of_the_stream(fs):
    length = int(round(2.0 * fs))
    rng = np.random.default_rng(1)
    x = rng.normal(size=(3 * length + 7, 6)) + _ramp(3 * length + 7) * 1e-3
    slices = np.stack([x[i * length:(i + 1) * length] for i in range(3)])
    got = LinearMoments.of_sequence(x, fs)
    assert (got.length, got.n_windows) == (length, 3)
    want = _direct_stats(slices, fs)
    s = summarize_sequence(x, fs)
    for value, expect in zip((s.cov, s.psd, s.norms, s.acf), want, strict=True):
        assert np.allclose(value, expect)
    tail = x.copy()
    tail[3 * length:] = 1e3  # samples past the last full window are not scored
    assert np.array_equal(summarize_sequence(tail, fs).cov, s.cov)
    head = x.copy()
    head[0] += 5.0
    assert not np.allclose(summarize_sequence(head, fs).cov, s.cov)


def test_a_custom_window_length_cuts_its_own_slices():
    x = np.random.default_rng(2).normal(size=(130, 6))
    slices = np.stack([x[0:25], x[25:50], x[50:75], x[75:100], x[100:125]])  # 0.5 s at 50 Hz
    got = summarize_sequence(x, FS, window_s=0.5)
    for value, expect in zip((got.cov, got.psd, got.norms, got.acf), _direct_stats(slices, FS), strict=True):
        assert np.allclose(value, expect)


def test_target_windows_are_scored_as_given():
    x = _ramp(600) * 1e-2 + np.sin(np.arange(600) / 7.0)[:, None]
    size, step = window_geometry(FS, 2.0, 0.5)
    starts = window_starts(len(x), size, step)
    windows = np.stack([x[s:s + size] for s in starts])
    assert list(starts) == [0, 50, 100, 150, 200, 250, 300, 350, 400, 450, 500]
    assert np.array_equal(windows[3], x[150:250])
    got = summarize_windows(windows, FS)
    for value, expect in zip((got.cov, got.psd, got.norms, got.acf), _direct_stats(windows, FS), strict=True):
        assert np.allclose(value, expect)


# -- D_stat built the way the fold builds it ---------------------------------------------------
@pytest.fixture(scope="module")
def fold():
    """Real 2 s windows of three classes (different dynamics), split into D_stat / D_rank."""
    rng = np.random.default_rng(8)
    size, step = window_geometry(FS, 2.0, 0.5)
    windows, labels = [], []
    for cls, freq in enumerate((1.0, 3.0, 6.0)):
        t = np.arange(3000) / FS
        x = np.stack([np.sin(2 * np.pi * freq * t + k) * (k + 1) for k in range(6)], axis=1)
        x = x + rng.normal(0, 0.2, x.shape)
        x[:, 1] += 9.81
        for s in window_starts(len(x), size, step):
            windows.append(x[s:s + size])
            labels.append(cls)
    windows, labels = np.stack(windows), np.array(labels)
    stat_idx, rank_idx = stat_rank_split(labels, seed=4)
    return windows, labels, stat_idx, rank_idx


def test_d_stat_holds_exactly_the_stat_half_of_each_class(fold):
    windows, labels, stat_idx, rank_idx = fold
    target = TargetStatistics(FS).fit(windows[stat_idx], labels[stat_idx])
    assert sorted(target.per_class_) == [0, 1, 2]
    assert target.n_windows_ == len(stat_idx)
    for cls in range(3):
        mine = windows[stat_idx][labels[stat_idx] == cls]
        cov, psd, norms, acf = _direct_stats(mine, FS)
        got = target.for_class(cls)
        assert np.allclose(got.cov, cov) and np.allclose(got.psd, psd)
        assert np.allclose(got.norms, norms) and np.allclose(got.acf, acf)
    pooled = _direct_stats(windows[stat_idx], FS)
    assert np.allclose(target.for_class(None).cov, pooled[0])
    assert np.allclose(target.for_class(None).acf, pooled[3])


def test_a_stream_made_of_the_d_stat_windows_scores_zero_against_its_class(fold):
    windows, labels, stat_idx, _ = fold
    target = TargetStatistics(FS).fit(windows[stat_idx], labels[stat_idx])
    losses = []
    for cls in range(3):
        mine = windows[stat_idx][labels[stat_idx] == cls]
        stream = mine.reshape(-1, 6)  # the candidate's 2 s windows are exactly these windows
        losses.append([float(sim_loss(summarize_sequence(stream, FS), target.for_class(c))) for c in range(3)])
        shifted = stream[25:]  # cut half a second later: different windows, nonzero loss
        assert sim_loss(summarize_sequence(shifted, FS), target.for_class(cls)) > 1e-3
    losses = np.array(losses)
    assert np.allclose(np.diag(losses), 0.0, atol=1e-9)
    assert (losses[~np.eye(3, dtype=bool)] > 0.1).all()


def test_d_stat_and_d_rank_halves_give_different_targets(fold):
    windows, labels, stat_idx, rank_idx = fold
    stat_t = TargetStatistics(FS).fit(windows[stat_idx], labels[stat_idx])
    rank_t = TargetStatistics(FS).fit(windows[rank_idx], labels[rank_idx])
    gaps = [float(sim_loss(stat_t.for_class(c), rank_t.for_class(c))) for c in range(3)]
    assert len(gaps) == 3 and all(0.0 < g < 0.5 for g in gaps)  # same dynamics, other windows


def test_target_statistics_fit_rejects_mismatched_input(fold):
    windows, labels, _, _ = fold
    message = r"^fit needs \(N, L, 6\) windows and N labels, N > 0$"
    with pytest.raises(ValueError, match=message):
        TargetStatistics(FS).fit(windows[:0], labels[:0])
    with pytest.raises(ValueError, match=message):
        TargetStatistics(FS).fit(windows, labels[:-1])
    with pytest.raises(ValueError, match=message):
        TargetStatistics(FS).fit(windows[0], labels[:1])
    one = TargetStatistics(FS, min_windows=1).fit(windows[:1], labels[:1])  # a single window is enough
    assert one.n_windows_ == 1 and list(one.per_class_) == [int(labels[0])]


def test_min_windows_is_inclusive(fold):
    windows, labels, _, _ = fold
    keep = np.concatenate([np.flatnonzero(labels == 0)[:20], np.flatnonzero(labels == 1)[:19]])
    target = TargetStatistics(FS).fit(windows[keep], labels[keep])
    assert target.min_windows == 20
    assert list(target.per_class_) == [0]


# -- the calibrator scores its candidates on the same windows --------------------------------
@pytest.fixture(scope="module")
def kinematics():
    root, local = walking()
    kin = simulate_kinematics(make_motion(9.0, 30.0, root, local), "waist", FS)
    noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples, FS, 0, "sim")
    return kin, noise


@pytest.mark.parametrize("base", [None, Rotation.from_euler("zxy", [20, -10, 40], degrees=True).as_matrix()])
def test_calibrator_nominal_loss_is_l_sim_of_the_nominal_readings_on_2s_slices(kinematics, fold, base):
    kin, noise = kinematics
    windows, labels, stat_idx, _ = fold
    target = TargetStatistics(FS).fit(windows[stat_idx], labels[stat_idx]).for_class(1)
    conv = Convention(axes=("up", "right", "forward"))
    eta = ETA_NOMINAL[None]
    mounting = eta_rotation(eta) if base is None else base[None]
    x = sensor_readings(kin, mounting, eta[:, 3:6], eta[:, 6:9], eta[:, 9], eta[:, 10], True, noise)[0]
    p = axes_matrix(conv.axes)
    aligned = np.concatenate([x[:, :3] @ p.T, x[:, 3:] @ p.T], axis=1)
    n = len(aligned) // 100
    slices = np.stack([aligned[i * 100:(i + 1) * 100] for i in range(n)])
    cov, psd, norms, acf = _direct_stats(slices, FS)
    expect = sim_loss(_summary(cov, psd, norms, acf), target)
    res = SimInTheLoopCalibrator(n_iterations=1, n_candidates=8).calibrate(
        kin, target, conv, np.random.default_rng(0), base_mounting=base, noise=noise)
    assert res.loss_nominal == pytest.approx(float(expect), rel=1e-9)
    assert res.loss_final <= res.loss_nominal
    assert res.loss_history == [res.loss_final]


# -- edges: two-sample windows, silent channels, messages ----------------------------------------
def test_two_sample_windows_follow_the_definitions():
    windows = np.random.default_rng(9).normal(size=(5, 2, 6))
    got = summarize_windows(windows, FS)
    cov, psd, norms, acf = _direct_stats(windows, FS)
    assert np.allclose(got.cov, cov) and np.allclose(got.norms, norms) and np.allclose(got.acf, acf)


def test_silent_and_near_silent_channels_stay_bounded():
    x = np.random.default_rng(3).normal(size=(400, 6))
    x[:, 4] = 0.0  # silent
    x[:, 5] *= 1e-8  # near silent: its energy is of the order of the guard epsilon
    s = summarize_sequence(x, FS)
    assert np.isfinite(s.psd).all() and (s.psd >= 0).all() and (s.psd.sum(-1) <= 1 + 1e-9).all()
    assert np.isfinite(s.acf).all() and (np.abs(s.acf) <= 1 + 1e-9).all() and (s.acf[4] == 0).all()
    silent = summarize_sequence(np.zeros((400, 6)), FS)
    assert sim_loss(s, silent) >= 0 and np.isfinite(sim_loss(s, silent))


def test_channel_count_errors_say_what_they_got():
    with pytest.raises(ValueError, match=r"^expected 6 channels \(acc xyz, gyr xyz\), got 5$"):
        summarize_windows(np.zeros((2, 10, 5)), FS)
    moments = LinearMoments.of_sequence(np.zeros((200, 4)), FS)
    with pytest.raises(ValueError, match=r"^expected 6 output channels \(acc xyz, gyr xyz\), got 5$"):
        moments.summarize(np.zeros((3, 4, 5)))


def test_channel_columns_give_the_statistics_of_the_dense_weights():
    rng = np.random.default_rng(2)
    features = rng.normal(size=(300, 16))
    weights = rng.normal(size=(4, 16, 6)) * (rng.random((1, 16, 6)) < 0.4)  # a sparse support per channel
    weights[:, :, 5] = 0.0  # a channel that reads nothing
    moments = LinearMoments.of_sequence(features, FS)
    cols, used = stats.channel_columns(weights)
    for c in range(6):
        support = np.flatnonzero(np.any(weights[:, :, c] != 0, axis=0))
        assert set(support) <= set(used[c]) and len(set(used[c])) == len(used[c])
        assert np.array_equal(cols[c], weights[:, used[c], c])
    fast = moments.summarize(weights)
    for n in range(4):
        with np.errstate(invalid="ignore"):
            cov, psd, norms, acf = _direct_stats(segment(features @ weights[n], int(2 * FS)), FS)
        assert np.allclose(fast.cov[n], cov) and np.allclose(fast.norms[n], norms)
        # the silent channel has no spectrum and no autocorrelation (0 here, 0/0 by definition)
        assert np.allclose(fast.psd[n, :5], psd[:5]) and np.allclose(fast.acf[n, :5], acf[:5])
        assert not fast.psd[n, 5].any() and not fast.acf[n, 5].any()


@pytest.mark.parametrize("axes", [("forward", "left", "up"), ("down", "backward", "right")])
def test_the_objective_scores_its_candidates_as_their_aligned_readings(kinematics, fold, axes):
    from vsmp_imu.grounding.calibrate import (
        ETA_HIGH,
        ETA_INIT_STD,
        ETA_LOW,
        StreamObjective,
        cem_candidates,
    )

    kin, noise = kinematics
    target = TargetStatistics(FS).fit(*fold[:2]).overall_
    conv = Convention(axes=axes, gravity_included=True)
    base = Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix()
    objective = StreamObjective(kin, target, conv, base, noise)
    eta = cem_candidates(ETA_NOMINAL, ETA_INIT_STD, ETA_LOW, ETA_HIGH, 6, np.random.default_rng(0))
    grav = np.array([True, False, True, True, False, True])
    got = objective(eta, grav)
    p = axes_matrix(axes)
    for n in range(6):
        readings = sensor_readings(kin, eta_rotation(eta[n:n + 1]) @ base, eta[n, 3:6], eta[n, 6:9], eta[n, 9],
                                   eta[n, 10], grav[n], noise)[0]
        aligned = np.concatenate([readings[:, :3] @ p.T, readings[:, 3:] @ p.T], axis=1)
        assert got[n] == pytest.approx(float(sim_loss(summarize_sequence(aligned, FS), target)), rel=1e-9)


def test_channel_columns_pad_to_the_largest_support_with_the_supported_features_first_in_order():
    weights = np.zeros((2, 40, 6))
    rng = np.random.default_rng(4)
    supports = [np.sort(rng.choice(40, size, replace=False)) for size in (7, 3, 5, 1, 0, 2)]
    for c, support in enumerate(supports):
        weights[0, support, c] = rng.normal(size=len(support)) + 3.0
    cols, used = stats.channel_columns(weights)
    assert used.shape == (6, 7) and cols.shape == (6, 2, 7)  # k = the largest support, no wider
    for c, support in enumerate(supports):
        assert used[c, :len(support)].tolist() == support.tolist()
        rest = sorted(set(range(40)) - set(support.tolist()))
        assert used[c, len(support):].tolist() == rest[:7 - len(support)]  # the padding, in order too
    silent = stats.channel_columns(np.zeros((3, 5, 6)))[1]
    assert silent.shape == (6, 1)  # at least one column when nothing is weighted


def test_the_moments_keep_their_pair_blocks_per_feature_set(signal):
    """Two weight sets with the same column count on other features: the second must not be
    scored with the first one's cached blocks (one LinearMoments and one MomentsBatch reused)."""
    features = np.concatenate([signal, signal[::-1] * 0.5], axis=1)  # 12 features
    first, second = np.zeros((3, 12, 6)), np.zeros((3, 12, 6))
    rng = np.random.default_rng(8)
    first[:, :6, :] = rng.normal(size=(3, 6, 6))
    second[:, 6:, :] = rng.normal(size=(3, 6, 6))
    reused = LinearMoments.of_sequence(features, FS)
    reused.summarize(first)
    fresh = LinearMoments.of_sequence(features, FS).summarize(second)
    got = reused.summarize(second)
    for name in ("cov", "psd", "norms", "acf"):
        np.testing.assert_allclose(getattr(got, name), getattr(fresh, name), rtol=1e-12, atol=1e-12)
    batch = stats.MomentsBatch([reused])
    for weights in (first, second):
        cols, used = stats.channel_columns(weights)
        summary = batch.summarize_channels(cols[None], used[None])
        alone = LinearMoments.of_sequence(features, FS).summarize(weights)
        np.testing.assert_allclose(summary.norms[0], alone.norms, rtol=1e-9)
        np.testing.assert_allclose(summary.cov[0], alone.cov, rtol=1e-9, atol=1e-9)


def test_sim_loss_against_a_target_per_candidate_set():
    """A target with leading axes of its own (S, 1, ...) scores each set of candidates (S, N, ...)
    against its own target, as one target would."""
    t = _target()
    other = _replace(t, cov=3.0 * np.eye(6), norms=np.array([5.0, 2.0, 1.0, 0.25]))
    psd = np.zeros((6, 6))
    psd[:, 1] = 1.0
    cands = [_summary(np.stack([np.eye(6), 2 * np.eye(6)]), np.stack([t.psd, psd]),
                      np.stack([t.norms, 2 * t.norms]), np.stack([t.acf, 0.2 * t.acf])),
             _summary(np.stack([3 * np.eye(6), np.eye(6)]), np.stack([psd, t.psd]),
                      np.stack([other.norms, t.norms]), np.stack([t.acf, t.acf]))]
    stacked = _summary(*(np.stack([getattr(c, f) for c in cands]) for f in ("cov", "psd", "norms", "acf")))
    targets = _summary(*(np.stack([getattr(x, f) for x in (t, other)])[:, None]
                         for f in ("cov", "psd", "norms", "acf")))
    got = sim_loss(stacked, targets)
    assert got.shape == (2, 2)
    np.testing.assert_allclose(got[0], sim_loss(cands[0], t), rtol=1e-12)
    np.testing.assert_allclose(got[1], sim_loss(cands[1], other), rtol=1e-12)


def test_the_objective_weights_give_the_aligned_readings_and_their_mean_acceleration(kinematics):
    from vsmp_imu.grounding.calibrate import StreamObjective

    kin, noise = kinematics
    axes = ("down", "backward", "right")
    base = Rotation.from_euler("xyz", [5, 15, -25], degrees=True).as_matrix()
    target = summarize_windows(np.zeros((2, 100, 6)), FS)
    objective = StreamObjective(kin, target, Convention(axes=axes), base, noise)
    eta = np.array([ETA_NOMINAL, ETA_NOMINAL + [10, -5, 20, 0.2, 0, -0.1, 0.01, 0, 0.02, 1.5, 0.5]])
    grav = np.array([True, False])
    weights = objective.weights(eta, grav)
    assert weights.shape == (2, objective.features.shape[1], 6)
    p = axes_matrix(axes)
    for n in range(2):
        readings = sensor_readings(kin, eta_rotation(eta[n:n + 1]) @ base, eta[n, 3:6], eta[n, 6:9], eta[n, 9],
                                   eta[n, 10], grav[n], noise)[0]
        aligned = np.concatenate([readings[:, :3] @ p.T, readings[:, 3:] @ p.T], axis=1)
        np.testing.assert_allclose(objective.features @ weights[n], aligned, atol=1e-9)
        np.testing.assert_allclose(objective.mean_acc(eta, grav)[n], aligned[:, :3].mean(axis=0), atol=1e-9)
