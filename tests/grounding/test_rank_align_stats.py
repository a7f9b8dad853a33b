"""Rank grounding, convention alignment, D_stat/D_rank split and L_sim statistics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import ks_2samp, spearmanr, wasserstein_distance

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.align import (
    Convention,
    ConventionAlignment,
    axes_matrix,
    infer_axes,
    sample_mounting_perturbation,
    signed_permutations,
)
from vsmp_imu.grounding.rank import RankGrounder
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.grounding.stats import (
    ACF_LAGS,
    LinearMoments,
    TargetStatistics,
    band_edges,
    segment,
    sim_loss,
    summarize_sequence,
    summarize_windows,
)
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G


@pytest.fixture
def rng():
    return np.random.default_rng(0)


# -- rank grounding ------------------------------------------------------------
def test_rank_grounding_matches_real_marginals_and_keeps_order(rng):
    synthetic = rng.gamma(2.0, 1.5, size=(240, 100, 6))
    real = rng.normal(2.0, 3.0, size=(300, 100, 6)).round(3)  # quantized like a sensor
    grounded = RankGrounder().fit(synthetic, real).transform(synthetic)
    for c in range(6):
        assert ks_2samp(grounded[..., c].ravel(), real[..., c].ravel()).statistic < 0.05
    rhos = [spearmanr(grounded[i, :, c], synthetic[i, :, c]).statistic for i in range(0, 240, 7) for c in range(6)]
    assert min(rhos) == pytest.approx(1.0, abs=1e-12)


def test_rank_grounding_changes_values(rng):
    synthetic = rng.normal(0, 1, size=(50, 100, 6))
    real = rng.normal(5, 2, size=(50, 100, 6))
    grounded = RankGrounder().fit(synthetic, real).transform(synthetic)
    assert abs(grounded.mean() - 5) < 0.2
    assert abs(grounded.std() - 2) < 0.2


def test_rank_grounding_per_class(rng):
    syn = np.concatenate([rng.normal(0, 1, (40, 50, 6)), rng.normal(0, 1, (40, 50, 6))])
    rea = np.concatenate([rng.normal(-3, 1, (40, 50, 6)), rng.normal(3, 1, (40, 50, 6))])
    ys, yr = np.repeat([0, 1], 40), np.repeat([0, 1], 40)
    g = RankGrounder(per_class=True).fit(syn, rea, ys, yr)
    out = g.transform(syn, ys)
    assert out[ys == 0].mean() == pytest.approx(-3, abs=0.2)
    assert out[ys == 1].mean() == pytest.approx(3, abs=0.2)
    pooled = RankGrounder().fit(syn, rea).transform(syn)
    assert abs(pooled[ys == 0].mean()) < 1.0  # pooled map cannot separate the classes


@pytest.mark.parametrize("per_class", [False, True])
def test_rank_grounding_adds_no_steps_with_few_real_windows(rng, per_class):
    # a near-constant class (lying): four real windows, each a plateau at its own level
    levels = np.array([0.0, 1.0, 2.5, 3.0])
    real = levels[:, None, None] + rng.normal(0, 0.02, size=(4, 100, 3))
    # synthetic windows: near-constant too, at levels spread over a range, slowly drifting
    drift = np.linspace(0.0, 0.05, 100)[None, :, None]
    syn = rng.uniform(-1, 1, size=(60, 1, 3)) + drift + rng.normal(0, 0.002, size=(60, 100, 3))
    ys, yr = np.zeros(60, int), np.zeros(4, int)
    grounded = RankGrounder(per_class=per_class, min_class_samples=10).fit(syn, real, ys, yr).transform(syn, ys)
    real_steps = np.abs(np.diff(real, axis=1)).max(axis=(0, 1))
    grounded_steps = np.abs(np.diff(grounded, axis=1)).max(axis=(0, 1))
    assert (grounded_steps <= real_steps).all(), (grounded_steps, real_steps)
    # still a map onto the real values: same mean and spread, close in distribution
    for c in range(3):
        g, r = grounded[..., c].ravel(), real[..., c].ravel()
        assert g.mean() == pytest.approx(r.mean(), abs=0.05)
        assert g.std() == pytest.approx(r.std(), rel=0.1)
        assert wasserstein_distance(g, r) < 0.35 * r.std() < 0.3 * wasserstein_distance(syn[..., c].ravel(), r)


def test_rank_grounding_rejects_bad_input(rng):
    with pytest.raises(ValidationError):
        RankGrounder().fit(rng.normal(size=(5, 10, 6)), rng.normal(size=(5, 10, 3)))
    bad = rng.normal(size=(5, 10, 6))
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValidationError, match="NaN"):
        RankGrounder().fit(bad, rng.normal(size=(5, 10, 6)))


# -- alignment ---------------------------------------------------------------------
def test_axes_matrix_maps_anatomical_words():
    p = axes_matrix(("up", "right", "forward"))
    sim = np.array([1.0, 2.0, 3.0])  # (left, up, forward)
    assert np.allclose(p @ sim, [2.0, -1.0, 3.0])
    with pytest.raises(ValidationError, match="same body direction"):
        axes_matrix(("up", "down", "left"))
    with pytest.raises(ValidationError):
        axes_matrix(("north", "up", "left"))


def test_alignment_gravity_units_and_axes():
    x = np.zeros((1, 4, 6))
    x[..., 1] = G  # static upright sensor: +g on its up axis
    x[..., 3] = 0.5  # gyro about the left axis
    grav = np.zeros((1, 4, 3))
    grav[..., 1] = G
    conv = Convention(axes=("up", "left", "forward"), gravity_included=True, acc_unit="g", gyr_unit="deg/s")
    out = ConventionAlignment(conv).transform(x, grav)
    assert np.allclose(out[0, 0, :3], [1.0, 0.0, 0.0])
    assert np.allclose(out[0, 0, 3:], [0.0, np.degrees(0.5), 0.0])
    linear = ConventionAlignment(Convention(gravity_included=False)).transform(x, grav)
    assert np.allclose(linear[..., :3], 0.0)
    with pytest.raises(ValidationError, match="gravity"):
        ConventionAlignment(Convention(gravity_included=False)).transform(x)


def test_signed_permutations_are_48_distinct_orthogonal():
    perms = signed_permutations()
    assert len(perms) == 48
    assert len({p.tobytes() for p in perms}) == 48
    assert all(np.allclose(p @ p.T, np.eye(3)) for p in perms)


def test_infer_axes_recovers_a_hidden_convention(rng):
    t = np.linspace(0, 20, 2000)
    acc = np.stack([np.sin(t), G + 2 * np.sin(2 * t), 0.3 * np.cos(t)], axis=1)
    gyr = np.stack([np.cos(3 * t), 0.1 * np.sin(t), 0.5 * np.sin(t)], axis=1)
    sim = np.concatenate([acc, gyr], axis=1)[None] + rng.normal(0, 0.05, (1, 2000, 6))
    hidden = axes_matrix(("down", "forward", "left"))
    real = np.concatenate([sim[..., :3] @ hidden.T, sim[..., 3:] @ hidden.T], axis=-1)
    p, _ = infer_axes(sim, real)
    assert np.allclose(p, hidden)


def test_mounting_perturbation_respects_prior_bounds(rng):
    for loc, bound in (("right_wrist", 30.0), ("waist", 30.0)):
        angles = np.array([sample_mounting_perturbation(loc, rng).as_euler("zxy", degrees=True) for _ in range(300)])
        assert np.abs(angles).max() <= bound + 1e-6
    waist = np.array([sample_mounting_perturbation("waist", rng).as_euler("zxy", degrees=True) for _ in range(300)])
    assert np.abs(waist[:, :2]).max() <= 15 + 1e-6
    assert np.abs(waist[:, :2]).max() > 10
    assert isinstance(sample_mounting_perturbation("waist", rng), Rotation)


# -- split --------------------------------------------------------------------------
def test_stat_rank_split_is_stratified_disjoint_and_seeded():
    labels = np.array([0] * 10 + [1] * 7 + [2] * 1)
    stat, rank = stat_rank_split(labels, seed=3)
    assert np.intersect1d(stat, rank).size == 0
    assert np.union1d(stat, rank).size == labels.size
    assert (labels[stat] == 0).sum() == 5 and (labels[rank] == 0).sum() == 5
    assert abs((labels[stat] == 1).sum() - (labels[rank] == 1).sum()) == 1
    assert (labels[stat] == 2).sum() == 1
    again = stat_rank_split(labels, seed=3)
    assert np.array_equal(stat, again[0])
    assert not np.array_equal(stat, stat_rank_split(labels, seed=4)[0])


# -- statistics ---------------------------------------------------------------------
def test_segment_shapes():
    x = np.zeros((3, 250, 6))
    assert segment(x, 100).shape == (3, 2, 100, 6)
    assert segment(np.zeros((50, 6)), 100).shape == (1, 50, 6)


def _direct_stats(windows: np.ndarray, fs: float):
    """Brute-force pooled statistics of windows (W, L, 6), straight from the definitions."""
    w_count, length, _ = windows.shape
    cov = np.mean([np.cov(w.T) for w in windows], axis=0)
    freqs = np.fft.rfftfreq(length, 1 / fs)
    edges = band_edges(fs)
    energy = np.zeros((6, 6))
    acf_num, acf_den = np.zeros((6, len(ACF_LAGS))), np.zeros(6)
    sq = np.zeros(4)
    for w in windows:
        c = w - w.mean(0)
        power = np.abs(np.fft.rfft(c, axis=0)) ** 2
        for b in range(6):
            lo, hi = edges[b], edges[b + 1]
            mask = (freqs >= lo) & (freqs <= hi) if b == 0 else (freqs > lo) & (freqs <= hi)
            energy[:, b] += power[mask].sum(0)
        for k, lag in enumerate(ACF_LAGS):
            if lag < length:
                acf_num[:, k] += (c[lag:] * c[:-lag]).sum(0)
        acf_den += (c**2).sum(0)
        sq += [(w[:, :3] ** 2).sum(1).mean(), (c[:, :3] ** 2).sum(1).mean(),
               (w[:, 3:] ** 2).sum(1).mean(), (c[:, 3:] ** 2).sum(1).mean()]
    psd = energy / energy.sum(1, keepdims=True)
    return cov, psd, np.sqrt(sq / w_count), acf_num / acf_den[:, None]


def test_statistics_match_their_definitions(rng):
    fs = 50.0
    windows = rng.normal(0, 1, (7, 100, 6)).cumsum(axis=1) * 0.1
    windows[..., 1] += G
    s = summarize_windows(windows, fs)
    cov, psd, norms, acf = _direct_stats(windows, fs)
    assert np.allclose(s.cov, cov)
    assert np.allclose(s.psd, psd)
    assert np.allclose(s.norms, norms)
    assert np.allclose(s.acf, acf)


def test_band_energy_finds_the_sine_band():
    fs = 50.0
    t = np.arange(100) / fs
    w = np.stack([np.sin(2 * np.pi * 3.0 * t)] * 6, axis=1)  # 3 Hz: band (2, 4]
    psd = summarize_windows(w[None], fs).psd
    assert np.allclose(psd.sum(-1), 1.0)
    assert (psd.argmax(-1) == 3).all()


def test_acf_of_periodic_signal():
    t = np.arange(200)
    w = np.sin(2 * np.pi * t / 20.0)[:, None].repeat(6, 1)
    acf = summarize_windows(w[None], 50.0).acf
    assert acf.shape == (6, 6)
    assert acf[0, 4] > 0.8  # lag 20 = one period
    assert acf[0, 3] < -0.8  # lag 10 = half a period


def test_linear_moments_score_a_population_exactly(rng):
    features = rng.normal(size=(640, 16))
    features[:, 9] = 1.0
    weights = rng.normal(size=(12, 16, 6))
    fast = LinearMoments.of_sequence(features, 50.0).summarize(weights)
    for n in (0, 7, 11):
        direct = _direct_stats(segment(features @ weights[n], 100), 50.0)
        for got, want in zip((fast.cov[n], fast.psd[n], fast.norms[n], fast.acf[n]), direct, strict=True):
            assert np.allclose(got, want)


def test_sim_loss_zero_at_target_and_grows_with_mismatch(rng):
    fs = 50.0
    real = rng.normal(0, 1, (30, 100, 6))
    real[..., 1] += G
    target = summarize_windows(real, fs)
    assert sim_loss(target, target) == pytest.approx(0.0, abs=1e-9)
    same = summarize_sequence(real.reshape(-1, 6), fs)
    noisy = summarize_sequence(real.reshape(-1, 6) * np.array([1, 1, 1, 3, 3, 3]), fs)
    assert sim_loss(noisy, target) > sim_loss(same, target) + 0.1


def test_target_statistics_fall_back_for_small_classes(rng):
    w = rng.normal(0, 1, (50, 100, 6))
    labels = np.array([0] * 45 + [1] * 5)
    ts = TargetStatistics(fs_hz=50.0, min_windows=20).fit(w, labels)
    assert 0 in ts.per_class_ and 1 not in ts.per_class_
    assert ts.for_class(1) is ts.overall_
    assert ts.for_class(0) is not ts.overall_


def test_target_statistics_threads_give_the_same_bytes(rng):
    w = rng.normal(0, 1, (90, 100, 6))
    labels = np.repeat([0, 1, 2], 30)
    one = TargetStatistics(fs_hz=50.0).fit(w, labels)
    three = TargetStatistics(fs_hz=50.0).fit(w, labels, threads=3)
    assert sorted(three.per_class_) == [0, 1, 2]
    for a, b in [(one.overall_, three.overall_)] + [(one.per_class_[c], three.per_class_[c]) for c in range(3)]:
        assert all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("cov", "psd", "norms", "acf"))


@pytest.mark.parametrize("per_class", [False, True])
def test_rank_grounding_threads_and_concatenation_give_the_same_bytes(rng, per_class):
    syn = rng.gamma(2.0, 1.0, size=(300, 40, 6))
    real = rng.normal(1.0, 2.0, size=(300, 40, 6))
    ys, yr = np.repeat([0, 1], 150), np.repeat([0, 1], 150)
    one = RankGrounder(per_class=per_class, min_class_samples=10).fit(syn, real, ys, yr)
    two = RankGrounder(per_class=per_class, min_class_samples=10, threads=2).fit(syn, real, ys, yr)
    assert np.array_equal(one.overall_.v_grid, two.overall_.v_grid)
    # samples of different lengths, one by one vs concatenated rows (above the threading size)
    samples = [rng.gamma(2.0, 1.0, size=(n, 6)) for n in (2000, 3000, 1500)]
    labels = [np.full(len(s), i % 2) for i, s in enumerate(samples)]
    each = [one.transform(s, lab if per_class else None) for s, lab in zip(samples, labels, strict=True)]
    rows = np.concatenate(samples)
    together = two.transform(rows, np.concatenate(labels) if per_class else None)
    assert np.array_equal(np.concatenate(each), together)


def test_class_balanced_pooling_follows_the_real_class_mix(rng):
    # real: 90 % class 0 around -3, 10 % class 1 around +3; synthetic has the opposite mix
    real = np.concatenate([rng.normal(-3, 1, (90, 50, 1)), rng.normal(3, 1, (10, 50, 1))])
    yr = np.repeat([0, 1], [90, 10])
    syn = np.concatenate([rng.normal(-3, 1, (10, 50, 1)), rng.normal(3, 1, (90, 50, 1))])
    ys = np.repeat([0, 1], [10, 90])
    balanced = RankGrounder().fit(syn, real, ys, yr).transform(syn)
    plain = RankGrounder(class_balanced=False).fit(syn, real, ys, yr).transform(syn)
    # balanced: each class keeps its place (class 1 stays positive); plain: class 1 is pushed negative
    assert balanced[ys == 1].mean() > 2.0 and balanced[ys == 0].mean() < -2.0
    assert plain[ys == 1].mean() < 0.0


def test_estimate_mounting_recovers_a_hidden_rotation(rng):
    from vsmp_imu.grounding.mounting import estimate_mounting

    hidden = Rotation.from_euler("zxy", [12.0, -8.0, 29.0], degrees=True)
    syn = np.array([[0, G, 0], [0, 0.5, 9.8], [0, 8.5, 4.9], [9.8, 0.5, 0.0], [0.0, 0.4, 0.2]])
    real = hidden.apply(syn) + rng.normal(0, 0.05, syn.shape)
    rot, rms = estimate_mounting(syn, real, np.array([10, 5, 3, 2, 50]))
    assert np.degrees((rot * hidden.inv()).magnitude()) < 1.0
    assert rms < 1.0
    ident, _ = estimate_mounting(syn[:1], real[:1])
    assert np.allclose(ident.as_quat(), Rotation.identity().as_quat())


def test_a_class_turned_half_round_gives_a_finite_residual_of_180_degrees():
    # one class's synthetic mean points opposite its real one: its residual angle is 180 degrees,
    # and the dot product of the two unit vectors can round to just below -1
    import warnings

    from vsmp_imu.grounding.mounting import estimate_mounting

    rng = np.random.default_rng(0)
    for _ in range(40):
        a, b = rng.normal(size=(2, 3))
        a, b = 9.8 * a / np.linalg.norm(a), 9.8 * b / np.linalg.norm(b)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # the rotation is poorly defined here
            _, rms = estimate_mounting(np.stack([b, -b]), np.stack([a, a]), weights=np.array([1.0, 1e-9]))
        assert rms == pytest.approx(180.0 * np.sqrt(1e-9 / (1 + 1e-9)), rel=1e-6)
