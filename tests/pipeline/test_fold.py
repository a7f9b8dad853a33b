"""Algorithm 1 on one fold of real HAPT data: isolation, grounding, filtering, provenance."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import spearmanr

from vsmp_imu.errors import ConfigError
from vsmp_imu.executor import LocalExecutor
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.synthetic import synthetic_budget
from vsmp_imu.pipeline.fold import FoldGenerator
from vsmp_imu.pipeline.sources import LibrarySmpSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary

TRAIN_SUBJECTS = ["2", "3", "4", "5"]
SMALL = dict(k=2, oversample=1.5, max_rounds=2)


@pytest.fixture(scope="module")
def hapt12():
    ds = load_dataset("hapt12")
    return ds.info, ds.windows()


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


def _generate(hapt12, library, config: GenerationSpec, cache_dir=None, workers=1, seed=0):
    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    budget = synthetic_budget(train.class_counts(), 0.05)
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    gen = FoldGenerator(config, LocalExecutor(workers, show_progress=False), cache_dir, library=library)
    return gen.generate(info, train, sources, budget, seed=seed, fold="test"), train, budget


@pytest.fixture(scope="module")
def fold(hapt12, library, tmp_path_factory):
    return _generate(hapt12, library, GenerationSpec(**SMALL), tmp_path_factory.mktemp("cache"))


def test_budget_respected_and_windows_shaped(fold, hapt12):
    out, train, budget = fold
    info, _ = hapt12
    assert out.windows.X.shape[1:] == (train.n_timesteps, 6)
    assert (np.bincount(out.windows.y, minlength=info.n_classes) <= budget).all()
    assert len(out.windows) > 0.3 * budget.sum()
    assert np.isfinite(out.windows.X).all()
    assert set(out.windows.subjects) == {"synthetic"}


def test_every_window_keeps_its_provenance_and_verdicts(fold):
    out, _, _ = fold
    windowed = [r for r in out.records if r.windowed]
    assert windowed and len(windowed) == len(out.generated)
    for rec in windowed:
        prov = rec.provenance.as_dict()
        for key in ("source", "smp_id", "prompt", "backend", "seed", "locations", "motion_verdict"):
            assert key in prov
        loc = prov["locations"]["waist"]
        assert loc["theta"]["segment"] and loc["gamma"]["axes"] == ["up", "forward", "left"]
        assert set(loc["eta"]["eta"]) >= {"roll_deg", "acc_noise_scale"}
        assert loc["eta"]["loss_final"] <= loc["eta"]["loss_nominal"]
        filters = [v.filter for v in rec.verdicts]
        assert filters[:2] == ["motion", "imu"]
        if rec.kept:
            assert all(v.passed for v in rec.verdicts)
        else:
            assert any(not v.passed and v.reason for v in rec.verdicts)
    selected = [r for r in windowed if r.selected]
    assert selected and all(r.kept for r in selected)


def test_rank_grounding_matches_d_rank_and_keeps_order(hapt12, library, fold):
    """Class-balanced KS < 0.05 per channel against D_rank; Spearman 1 with the aligned input."""
    out, train, _ = fold
    _, rank_idx = stat_rank_split(train.y, 0)
    d_rank = train[rank_idx]
    ok = [r for r in out.samples if not r.error and r.signals]
    assert ok
    info, _ = hapt12
    from vsmp_imu.pipeline.fold import ground, location_plan

    grounded, mappings = ground(GenerationSpec(**SMALL), info, ok, d_rank, location_plan(info))
    # every class has real windows here: none is left unmapped
    assert set(mappings) == {"waist"} and set(mappings["waist"].values()) <= {"class", "pooled"}
    assert set(mappings["waist"]) == {info.label_names[r.label_index] for r in ok}
    syn = np.concatenate([g["waist"] for g in grounded])
    labels = np.concatenate([np.full(len(g["waist"]), r.label_index) for g, r in zip(grounded, ok, strict=True)])
    real_share = np.bincount(d_rank.y, minlength=info.n_classes) / len(d_rank)
    syn_share = np.bincount(labels, minlength=info.n_classes) / len(labels)
    weights = real_share[labels] / syn_share[labels]
    real = d_rank.X.reshape(-1, 6).astype(np.float64)
    for c in range(6):
        assert _weighted_ks(syn[:, c], weights, real[:, c]) < 0.05
    for g, r in zip(grounded[:10], ok[:10], strict=True):
        for c in range(6):
            rho = spearmanr(g["waist"][:, c], r.signals["waist"][:, c]).statistic
            assert rho == pytest.approx(1.0, abs=1e-9)


def _weighted_ks(x: np.ndarray, w: np.ndarray, y: np.ndarray) -> float:
    grid = np.quantile(np.concatenate([x, y]), np.linspace(0, 1, 2001))
    order = np.argsort(x)
    fx = np.interp(grid, x[order], np.cumsum(w[order]) / w.sum(), left=0.0, right=1.0)
    fy = np.searchsorted(np.sort(y), grid, side="right") / len(y)
    return float(np.abs(fx - fy).max())


def test_ablation_switches_change_what_they_say(hapt12, library, tmp_path):
    out, _, _ = _generate(hapt12, library, GenerationSpec(sim_in_the_loop=False, quality_filter=False,
                                                            rank_grounding=False, k=1, oversample=1.0,
                                                            max_rounds=1))
    windowed = [r for r in out.records if r.windowed]
    assert windowed and all(r.kept and r.verdicts == [] for r in windowed)
    assert all(r.provenance.locations["waist"].eta is None for r in windowed)


def test_same_seed_same_bytes_any_worker_count(hapt12, library, tmp_path):
    config = GenerationSpec(k=1, oversample=1.0, max_rounds=1)
    one, _, _ = _generate(hapt12, library, config, workers=1)
    two, _, _ = _generate(hapt12, library, config, workers=2)
    assert one.windows.X.tobytes() == two.windows.X.tobytes()
    assert [r.sample for r in one.records] == [r.sample for r in two.records]
    other, _, _ = _generate(hapt12, library, config, seed=1)
    assert other.windows.X.tobytes() != one.windows.X.tobytes()


class _Recorder:
    """A local executor that notes which items went through `map` and which through `start`."""

    def __init__(self, workers: int, start: bool = True, fail_map: bool = False) -> None:
        self.inner, self.workers, self.fail_map = LocalExecutor(workers, show_progress=False), workers, fail_map
        self.mapped, self.started, self.cancelled = [], [], 0
        if start:
            self.start = self._start

    def map(self, fn, tasks, desc="working"):
        if self.fail_map:
            raise RuntimeError("a worker broke")
        self.mapped += list(tasks)
        return self.inner.map(fn, tasks, desc)

    def _start(self, fn, item, desc="working"):
        self.started.append(item)
        started = self.inner.start(fn, item, desc)
        cancel = started.cancel

        def counted() -> None:
            self.cancelled += 1
            cancel()
        started.cancel = counted
        return started


def _run(hapt12, library, config, executor):
    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    budget = synthetic_budget(train.class_counts(), 0.05)
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    return FoldGenerator(config, executor, None, library=library).generate(info, train, sources, budget, 0, "test")


def test_the_filter_models_are_fitted_beside_the_fold_and_give_the_same_bytes(hapt12, library):
    """The filter job starts before the fold's own steps (`executor.start`), not inside a synthesis
    round; an executor with only `map` runs it there; either way the windows are the same bytes."""
    config = GenerationSpec(k=1, oversample=1.0, max_rounds=1)
    pooled = _Recorder(2)
    two = _run(hapt12, library, config, pooled)
    assert [type(item).__name__ for item in pooled.started] == ["FilterJob"]
    assert not any(type(item).__name__ == "FilterJob" for item in pooled.mapped)
    assert pooled.cancelled == 1  # the fold's end cancels it; after its result, that is a no-op
    map_only = _Recorder(1, start=False)
    one = _run(hapt12, library, config, map_only)
    assert type(map_only.mapped[0]).__name__ == "FilterJob" and not hasattr(map_only, "start")
    assert one.windows.X.tobytes() == two.windows.X.tobytes()
    assert [r.sample for r in one.records] == [r.sample for r in two.records]


def test_an_error_in_the_fold_cancels_the_started_filter_job(hapt12, library):
    broken = _Recorder(2, fail_map=True)
    with pytest.raises(RuntimeError, match="a worker broke"):
        _run(hapt12, library, GenerationSpec(k=1, oversample=1.0, max_rounds=1), broken)
    assert len(broken.started) == 1 and broken.cancelled == 1


def test_refill_tops_up_classes_short_of_their_budget(hapt12, library, tmp_path):
    """A refill pass synthesizes more samples for the classes the filter left short, keeps the
    first pass's samples, delivers more of the budget, and is the same bytes with 2 workers."""
    base = dict(k=1, oversample=1.0, max_rounds=1)
    plain, _, budget = _generate(hapt12, library, GenerationSpec(**base), tmp_path)
    assert plain.summary["shortfall"], "the test needs a class short of its budget"
    refilled, _, _ = _generate(hapt12, library, GenerationSpec(**base, refill=1), tmp_path)
    short = set(plain.summary["shortfall"])
    for name, counts in refilled.summary["per_class"].items():
        before = plain.summary["per_class"][name]["samples"]
        assert (counts["samples"] > before) == (name in short), name
        assert counts["selected"] <= counts["budget"]
    assert {r.key for r in plain.samples} <= {r.key for r in refilled.samples}
    assert len(refilled.windows) > len(plain.windows)
    assert sum(refilled.summary["shortfall"].values()) < sum(plain.summary["shortfall"].values())
    two, _, _ = _generate(hapt12, library, GenerationSpec(**base, refill=1), tmp_path, workers=2)
    assert two.windows.X.tobytes() == refilled.windows.X.tobytes()
    assert [r.sample for r in two.records] == [r.sample for r in refilled.records]


def test_refill_must_not_be_negative():
    from vsmp_imu.errors import ConfigError

    with pytest.raises(ConfigError, match="refill"):
        GenerationSpec(refill=-1)


def test_gravity_norm_gives_the_grounded_windows_the_real_gravity_reading(hapt12, library, tmp_path):
    info, windows = hapt12
    out, train, _ = _generate(hapt12, library, GenerationSpec(**SMALL, gravity_norm=True), tmp_path)
    plain, _, _ = _generate(hapt12, library, GenerationSpec(**SMALL), tmp_path)  # same samples (cache)
    static = [info.label_names.index(n) for n in ("SITTING", "STANDING", "LAYING")]

    def spread(w):
        norms = np.linalg.norm(w.X[np.isin(w.y, static)][..., :3].mean(axis=1), axis=1)
        return np.median(norms), np.quantile(norms, 0.9) - np.quantile(norms, 0.1)

    real_median, real_spread = spread(train)
    (kept_median, kept_spread), plain_spread = spread(out.windows), spread(plain.windows)[1]
    assert abs(kept_median - real_median) < 0.05 * real_median
    assert kept_spread < plain_spread  # the channel-wise map alone spreads the gravity reading


def test_the_side_evidence_reaches_the_summary_and_every_sample_of_the_class(fold):
    """The lying transitions' and the stairs' sides come from the training windows (pipeline.side):
    the summary records each decision and every sample of the class is a variant of the decided SMP."""
    from vsmp_imu.smp import SMP

    out, _, _ = fold
    sides = out.summary["side_evidence"]
    assert set(sides) == {"SIT_TO_LIE", "LIE_TO_SIT", "STAND_TO_LIE", "LIE_TO_STAND",
                          "WALKING_UPSTAIRS", "WALKING_DOWNSTAIRS"}
    for label, (rec,) in sides.items():
        assert rec["used"] and rec["source"] == f"library:{label.lower()}"
        tasks = [t for t in out.tasks if t.label == label]
        assert tasks
        for task in tasks:
            smp = SMP.model_validate_json(task.smp_json)
            assert smp.uncertainty.dominant_side == pytest.approx(rec["uncertainty"])
            assert smp.execution_attributes.dominant_side in ("left", "right")


def test_movement_texture_brings_the_gyroscope_hf_share_toward_the_real_one(hapt12, library, tmp_path):
    """The samples' 3-12 Hz gyroscope energy, relative to their 0.3-3 Hz energy, is far below the
    real windows' without the texture and near it with the texture (the same motions, from the same
    seeds); the summary records the ratios and which each class got."""
    from vsmp_imu.grounding.texture import HF_BAND_HZ, LF_BAND_HZ, _band

    info, _ = hapt12
    plain, train, _ = _generate(hapt12, library, GenerationSpec(**SMALL, texture=False), tmp_path)
    textured, _, _ = _generate(hapt12, library, GenerationSpec(**SMALL), tmp_path)
    assert "texture" not in plain.summary
    summary = textured.summary["texture"]["waist"]
    assert len(summary["pooled"]) == 6 and set(summary["mapping"].values()) <= {"class", "pooled"}
    assert summary["mapping"]["WALKING"] == "class"
    moving = [info.label_names.index(n) for n in ("WALKING", "STAND_TO_SIT", "SIT_TO_LIE", "LIE_TO_STAND")]

    def gyro_ratio(w):
        X = w.X[np.isin(w.y, moving)][..., 3:6].astype(np.float64)
        hf, lf = _band(X, HF_BAND_HZ, info.fs_hz, 1), _band(X, LF_BAND_HZ, info.fs_hz, 1)
        return np.sqrt((hf ** 2).sum() / (lf ** 2).sum())

    real, before, after = gyro_ratio(train), gyro_ratio(plain.windows), gyro_ratio(textured.windows)
    assert before < 0.3 * real
    assert 0.6 * real < after < 1.5 * real


def test_the_sample_worker_adds_the_texture_its_task_carries(hapt12, library, tmp_path):
    """Each sample's texture is added in its worker from the class's ratios in the task, with noise
    from rng_for(seed, fold, key, "texture"): the textured signal is the untextured one plus
    `add_texture` of it, and the task's ratios are those the summary reports for the class."""
    from vsmp_imu.grounding.texture import add_texture
    from vsmp_imu.seeding import rng_for

    plain, _, _ = _generate(hapt12, library, GenerationSpec(**SMALL, texture=False), tmp_path)
    textured, _, _ = _generate(hapt12, library, GenerationSpec(**SMALL), tmp_path)
    assert all(t.texture is None for t in plain.tasks)
    summary = textured.summary["texture"]["waist"]
    before = {r.key: r for r in plain.samples}
    info, _ = hapt12
    pairs = [(t, r) for t, r in zip(textured.tasks, textured.samples, strict=True) if not r.error]
    assert len(pairs) > 20
    for task, sample in pairs[::7]:
        assert task.key == sample.key and task.texture["fold"] == "test" and task.texture["seed"] == 0
        kappa = task.texture["kappa"]["waist"]
        own = summary["classes"].get(task.label) if summary["mapping"][task.label] == "class" else summary["pooled"]
        assert np.allclose(kappa, own, atol=1e-4)
        rng = rng_for(0, "test", task.key, "texture")
        expected = add_texture(before[task.key].signals["waist"], kappa, info.fs_hz, rng)
        assert np.array_equal(sample.signals["waist"], expected)


@pytest.mark.parametrize("pooled", [True, False])
def test_a_class_without_real_windows_is_calibrated_against_pooled_statistics_only_if_asked(hapt12, pooled):
    """Sim-in-the-loop targets: each seen class its own D_stat summary; a class with no window
    the pooled summary, or none (eta nominal) with `pooled_calibration` off."""
    from vsmp_imu.pipeline.fold import location_plan, location_tasks, target_statistics

    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    unseen = info.label_names.index("STANDING")
    d_stat = train[train.y != unseen]
    stats = target_statistics(info, d_stat)
    mountings = {loc.name: (0.0, 0.0, 0.0, 1.0) for loc in info.locations}
    tasks = location_tasks(GenerationSpec(pooled_calibration=pooled), info, location_plan(info), stats, mountings)
    (waist,) = tasks["STANDING"]
    pooled_cov = stats["waist"].for_class(None).cov.tolist()
    assert (waist.target is not None) is pooled
    if pooled:
        assert waist.target["cov"] == pooled_cov
    (sitting,) = tasks["SITTING"]
    own = stats["waist"].for_class(info.label_names.index("SITTING")).cov.tolist()
    assert sitting.target["cov"] == own != pooled_cov


def test_an_unseen_posture_keeps_the_nominal_sensor_and_an_unseen_movement_is_calibrated(hapt12, library):
    """With no real window of it, standing (a held posture in its SMP) gets no sim-in-the-loop
    target and the generation summary says so, walking (cyclic) gets the pooled one; a seen
    posture keeps its own, and the switch off calibrates the unseen posture as before."""
    from vsmp_imu.pipeline.fold import prepare

    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    gone = [info.label_names.index(n) for n in ("STANDING", "WALKING")]
    seen = train[~np.isin(train.y, gone)]
    setup = prepare(GenerationSpec(), info, seen, sources, seed=0)
    targets = {label: setup.locations[label][0].target for label in ("STANDING", "WALKING", "SITTING")}
    assert setup.nominal_sensor == ("STANDING",) and targets["STANDING"] is None
    assert targets["WALKING"] is not None and targets["SITTING"] is not None
    assert targets["WALKING"]["cov"] != targets["SITTING"]["cov"]
    off = prepare(GenerationSpec(nominal_unseen_postures=False), info, seen, sources, seed=0)
    assert off.nominal_sensor == () and off.locations["STANDING"][0].target == targets["WALKING"]
    assert prepare(GenerationSpec(), info, train, sources, seed=0).nominal_sensor == ()


def test_a_class_without_real_windows_spreads_its_samples_over_k_unseen_variants(library):
    """Slot s uses variant s mod K: K = k for a class with real windows, k_unseen for one with none
    (the variants a class with windows gets are the first of them); both must be >= 1."""
    from vsmp_imu.pipeline.fold import sample_tasks

    bases = [("library:walking", library.get("walking").smp)]
    spec = GenerationSpec(k=4, k_unseen=16)

    def variants(class_windows):
        tasks = sample_tasks(spec, "WALKING", 0, bases, range(32), 0, "f1", 50.0, (), library,
                             class_windows=class_windows)
        return {t.variant: t.smp_json for t in tasks}

    seen, unseen = variants(120), variants(0)
    assert sorted(seen) == list(range(4)) and sorted(unseen) == list(range(16))
    assert all(unseen[i] == seen[i] for i in range(4))
    assert len(set(unseen.values())) == 16
    assert spec.variants_for(None) == 4 and spec.variants_for(0) == 16
    for bad in ({"k": 0}, {"k_unseen": 0}):
        with pytest.raises(ConfigError):
            GenerationSpec(**bad)


def test_the_summary_names_the_classes_that_got_k_unseen_variants(hapt12, library):
    """A fold whose only budgeted class has no real window: its first round holds at least
    k_unseen samples, one per variant, and the generation summary says how many it got."""
    info, windows = hapt12
    gone = info.label_names.index("STAND_TO_SIT")
    train = windows.where_subjects(TRAIN_SUBJECTS)
    train = train[np.flatnonzero(train.y != gone)]
    budget = np.zeros(info.n_classes, np.int64)
    budget[gone] = 4
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    spec = GenerationSpec(k=2, k_unseen=6, oversample=1.0, max_rounds=1, quality_filter=False)
    out = FoldGenerator(spec, LocalExecutor(1, show_progress=False), library=library).generate(
        info, train, sources, budget, seed=0, fold="test")
    assert out.summary["variants_per_smp"] == {"STAND_TO_SIT": 6}
    assert sorted({t.variant for t in out.tasks}) == list(range(6))
    same = replace(spec, k_unseen=2)
    assert "variants_per_smp" not in FoldGenerator(same, LocalExecutor(1, show_progress=False),
                                                   library=library).generate(
        info, train, sources, budget, seed=0, fold="test").summary


def test_a_class_without_real_windows_keeps_its_values_when_seen_classes_are_generated_too(hapt12, library):
    """The seen classes' rank map is not lent to a class with no real training window: its
    windows are the same whether or not a seen class is generated beside it, and the summary
    says it was left unmapped (docs/results.md, "The seen classes' map is not lent to an
    unseen class")."""
    info, windows = hapt12
    gone, seen = info.label_names.index("STAND_TO_SIT"), info.label_names.index("SITTING")
    train = windows.where_subjects(TRAIN_SUBJECTS)
    train = train[np.flatnonzero(train.y != gone)]
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    # the grounded values, before the intensity spread (whose factors follow the windows' order)
    spec = GenerationSpec(k=2, k_unseen=2, oversample=1.0, max_rounds=1, quality_filter=False,
                          unseen_intensity=None)

    def unseen_windows(budgeted):
        budget = np.zeros(info.n_classes, np.int64)
        budget[budgeted] = 3
        out = FoldGenerator(spec, LocalExecutor(1, show_progress=False), library=library).generate(
            info, train, sources, budget, seed=0, fold="test")
        labels = np.array([r.label for r in out.records[:len(out.generated)]])
        return out.generated[labels == "STAND_TO_SIT"], out.summary["rank_map"]["waist"]

    alone, alone_map = unseen_windows([gone])
    beside, beside_map = unseen_windows([gone, seen])
    assert alone_map == {"STAND_TO_SIT": "none"}
    assert beside_map == {"SITTING": "class", "STAND_TO_SIT": "none"}
    assert len(alone) > 0 and np.array_equal(alone, beside)


def test_only_the_selected_windows_of_a_class_without_real_windows_get_an_intensity_factor(hapt12, library,
                                                                                           tmp_path):
    """With `unseen_intensity` (the default), each selected window of the unseen class has its gyroscope's
    deviations from its mean scaled by its recorded factor; a seen class, the accelerometer and
    the unselected windows are the same bytes as without; the summary and the Parquet output
    carry the factors."""
    import pyarrow.parquet as pq

    from vsmp_imu.pipeline.output import write_output

    info, windows = hapt12
    gone, seen = info.label_names.index("STAND_TO_SIT"), info.label_names.index("SITTING")
    train = windows.where_subjects(TRAIN_SUBJECTS)
    train = train[np.flatnonzero(train.y != gone)]
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    budget = np.zeros(info.n_classes, np.int64)
    budget[[gone, seen]] = 3
    spec = GenerationSpec(k=2, k_unseen=2, oversample=2.0, max_rounds=1, quality_filter=False)

    def run(s):
        return FoldGenerator(s, LocalExecutor(1, show_progress=False), tmp_path / "cache", library=library).generate(
            info, train, sources, budget, seed=0, fold="test")

    assert spec.unseen_intensity == (0.7, 2.0)  # the default
    plain, spread = run(replace(spec, unseen_intensity=None)), run(spec)
    n = len(plain.generated)
    labels = np.array([r.label for r in spread.records[:n]])
    selected = np.array([r.selected for r in spread.records[:n]])
    factors = np.array([np.nan if r.intensity is None else r.intensity for r in spread.records[:n]])
    target = selected & (labels == "STAND_TO_SIT")
    assert target.sum() == 3 and np.isfinite(factors[target]).all() and np.isnan(factors[~target]).all()
    gyro = [i for i, c in enumerate(info.channel_names) if "gyr" in c]
    rest = [i for i in range(len(info.channel_names)) if i not in gyro]
    np.testing.assert_array_equal(spread.generated[~target], plain.generated[~target])
    np.testing.assert_array_equal(spread.generated[target][:, :, rest], plain.generated[target][:, :, rest])
    before, after = plain.generated[target][:, :, gyro], spread.generated[target][:, :, gyro]
    np.testing.assert_allclose(after.std(axis=1) / before.std(axis=1),
                               np.repeat(factors[target][:, None], len(gyro), axis=1), rtol=1e-3)
    assert spread.summary["intensity_spread"]["STAND_TO_SIT"]["windows"] == 3
    assert "SITTING" not in spread.summary["intensity_spread"] and "intensity_spread" not in plain.summary
    write_output(tmp_path / "out", spread, {})
    column = pq.read_table(tmp_path / "out" / "synthetic.parquet").column("intensity").to_pylist()
    assert [c for c in column if c is not None] == factors[target].tolist()


def test_with_seen_intensity_a_class_with_real_windows_gets_the_spread_its_real_windows_show(hapt12, library,
                                                                                             tmp_path, monkeypatch):
    """With `seen_intensity`, each selected window of a class with real windows has its gyroscope's
    deviations from its mean scaled by its recorded factor, exp(s z) with s the log-intensity spread
    the class's windows lack against its real ones; the rest is the same bytes as without."""
    import vsmp_imu.grounding.intensity as intensity

    monkeypatch.setattr(intensity, "MATCH_MIN_WINDOWS", 3)  # a small test budget
    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    names = ("SIT_TO_STAND", "LIE_TO_STAND")
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    budget = np.zeros(info.n_classes, np.int64)
    budget[[info.label_names.index(n) for n in names]] = 6
    spec = GenerationSpec(k=2, oversample=2.0, max_rounds=1, quality_filter=False)
    assert spec.seen_intensity is False  # off by default

    def run(s):
        return FoldGenerator(s, LocalExecutor(1, show_progress=False), tmp_path / "cache", library=library).generate(
            info, train, sources, budget, seed=0, fold="test")

    plain, matched = run(spec), run(replace(spec, seen_intensity=True))
    n = len(plain.generated)
    labels = np.array([r.label for r in matched.records[:n]])
    selected = np.array([r.selected for r in matched.records[:n]])
    factors = np.array([np.nan if r.intensity is None else r.intensity for r in matched.records[:n]])
    gyro = [i for i, c in enumerate(info.channel_names) if "gyr" in c]
    rest = [i for i in range(len(info.channel_names)) if i not in gyro]
    spreads = {name: matched.summary["intensity_match"][name]["spread"] for name in names}
    assert any(s > 0 for s in spreads.values()) and "intensity_match" not in plain.summary
    for name in names:
        c = info.label_names.index(name)
        mine = selected & (labels == name)
        real = train.X[train.y == c]
        assert spreads[name] == pytest.approx(intensity.missing_spread(real, plain.generated[mine], np.array(gyro)),
                                              abs=1e-4)
        assert np.isfinite(factors[mine]).all() == (spreads[name] > 0)
    target = np.isfinite(factors)
    assert target.sum() > 0 and not (target & ~selected).any()
    np.testing.assert_array_equal(matched.generated[~target], plain.generated[~target])
    np.testing.assert_array_equal(matched.generated[:, :, rest], plain.generated[:, :, rest])
    before, after = plain.generated[target][:, :, gyro], matched.generated[target][:, :, gyro]
    np.testing.assert_allclose(after.std(axis=1) / before.std(axis=1),
                               np.repeat(factors[target][:, None], len(gyro), axis=1), rtol=1e-3)


def test_window_levels_move_a_transitions_window_means_onto_its_real_ones(hapt12):
    """Stage 5b (grounding.levels) on the fold's windows: a transition with MIN_WINDOWS or more D_rank
    windows gets its window means mapped, one with fewer and a steady class keep theirs."""
    from types import SimpleNamespace

    from vsmp_imu.grounding.levels import MIN_WINDOWS
    from vsmp_imu.pipeline.fold import WindowSet, level_windows

    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    d_rank = train[stat_rank_split(train.y, 0)[1]]
    names = info.label_names
    lie, stand_up, walk = names.index("STAND_TO_LIE"), names.index("SIT_TO_STAND"), names.index("WALKING")
    # a low budget's handful of sit-to-stand windows: fewer than MIN_WINDOWS
    drop = np.flatnonzero(d_rank.y == stand_up)[MIN_WINDOWS - 2:]
    d_rank = d_rank[~np.isin(np.arange(len(d_rank)), drop)]
    assert (d_rank.y == lie).sum() >= MIN_WINDOWS > (d_rank.y == stand_up).sum() > 0
    other = windows.where_subjects(["6", "7", "8", "9", "10"])
    pick = np.isin(other.y, [lie, stand_up, walk])
    X, y = other.X[pick].astype(np.float32), other.y[pick]
    X[..., 0] += 3.0  # "synthetic" windows: other subjects' real windows, 3 m/s^2 off on one axis

    def windowset():
        return WindowSet(X.copy(), y, [SimpleNamespace(locations=["waist"]) for _ in y])

    ws = windowset()
    summary = level_windows(GenerationSpec(), info, ws, d_rank)
    assert list(summary["waist"]["classes"]) == ["STAND_TO_LIE"]
    assert summary["waist"]["too_few"] == {"SIT_TO_STAND": int((d_rank.y == stand_up).sum())}
    real = d_rank.X[d_rank.y == lie, :, 0].mean()
    assert abs(X[y == lie, :, 0].mean() - real) > 2.5
    assert abs(ws.X[y == lie, :, 0].mean() - real) < 0.5
    assert np.array_equal(ws.X[y != lie], X[y != lie])
    off = windowset()
    assert level_windows(GenerationSpec(window_levels=False), info, off, d_rank) == {}
    assert np.array_equal(off.X, X)


def test_posture_levels_move_a_held_postures_window_means_and_leave_a_cyclic_class(hapt12, library):
    """With `posture_levels` and the library's SMPs as sources, a class whose SMP holds a posture
    (STANDING) gets its window means mapped as a transition does; a gait (WALKING) keeps its windows,
    and so do the postures by default."""
    from types import SimpleNamespace

    from vsmp_imu.pipeline.fold import WindowSet, holds_posture, level_classes, level_windows

    info, windows = hapt12
    names = info.label_names
    sources = LibrarySmpSource(library).smps("hapt12", names)
    postures = {n for n in names if holds_posture(sources, n)}
    assert postures == {"SITTING", "STANDING", "LAYING"}
    events = {n for n, share in zip(names, info.share_vector(), strict=True) if share < 1.0}
    assert {names[c] for c in level_classes(GenerationSpec(posture_levels=True), info, sources)} == postures | events
    assert {names[c] for c in level_classes(GenerationSpec(), info, sources)} == events
    train = windows.where_subjects(TRAIN_SUBJECTS)
    d_rank = train[stat_rank_split(train.y, 0)[1]]
    stand, walk = names.index("STANDING"), names.index("WALKING")
    other = windows.where_subjects(["6", "7", "8", "9", "10"])
    pick = np.isin(other.y, [stand, walk])
    X, y = other.X[pick].astype(np.float32), other.y[pick]
    X[..., 1] += 3.0  # "synthetic" windows: other subjects' real ones, tilted on one axis

    def level(spec):
        ws = WindowSet(X.copy(), y, [SimpleNamespace(locations=["waist"]) for _ in y])
        return ws, level_windows(spec, info, ws, d_rank, sources)

    ws, summary = level(GenerationSpec(posture_levels=True))
    assert list(summary["waist"]["classes"]) == ["STANDING"]
    real = d_rank.X[d_rank.y == stand, :, 1].mean()
    assert abs(X[y == stand, :, 1].mean() - real) > 1.5
    assert abs(ws.X[y == stand, :, 1].mean() - real) < 0.3
    assert np.array_equal(ws.X[y == walk], X[y == walk])
    ws, summary = level(GenerationSpec())
    assert summary["waist"]["classes"] == {} and np.array_equal(ws.X, X)


def test_a_retimed_transition_leaves_the_mounting_where_it_was(hapt12, library):
    """The nominal mounting comes from the classes that hold a posture or repeat a rhythm: a
    transition's timing (examples/hapt12_timed) changes its own samples only. With fewer than two
    such classes every class counts, and there the retiming turns the sensor."""
    from vsmp_imu.pipeline.fold import location_plan, nominal_mountings

    info, windows = hapt12
    train = windows.where_subjects(TRAIN_SUBJECTS)
    d_stat = train[stat_rank_split(train.y, 0)[0]]
    plan = location_plan(info)
    timed = str(Path(__file__).parents[2] / "examples" / "hapt12_timed")

    def mounting(dirs: tuple[str, ...], labels=None) -> np.ndarray:
        lib = ActivityLibrary.load([Path(d) for d in dirs]) if dirs else library
        sources = LibrarySmpSource(lib).smps("hapt12", info.label_names)
        sources = {k: v for k, v in sources.items() if labels is None or k in labels}
        return np.array(nominal_mountings(GenerationSpec(library_dirs=dirs), info, plan, sources, d_stat)["waist"])

    plain, retimed = mounting(()), mounting((timed,))
    assert not np.allclose(plain, [0, 0, 0, 1])  # a mounting was estimated
    assert np.array_equal(plain, retimed)
    few = ("STANDING", "SIT_TO_LIE", "LIE_TO_SIT", "STAND_TO_SIT")  # one posture only
    assert not np.allclose(mounting((), few), mounting((timed,), few), atol=1e-6)
