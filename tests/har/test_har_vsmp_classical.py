"""`vsmp+classical`: VSMP-IMU windows plus classical augmentation of real and VSMP-IMU windows."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.methods import REGISTRY, make, register_all
from vsmp_imu.pipeline import combined
from vsmp_imu.pipeline.combined import VsmpClassicalMethod, vsmp_share
from vsmp_imu.pipeline.spec import GenerationSpec

# the fake VSMP-IMU windows' gyroscope norm: augmented copies keep it (rotations keep norms), the
# real windows' gyroscope is small
FAKE_LEVEL = 500.0


class FakeVsmp:
    """Stands in for the VSMP-IMU chain: `per_class` windows of every class with a budget."""

    per_class = 5

    def __init__(self, spec=None, name="vsmp"):
        self.spec = spec

    def generate(self, context: FoldContext) -> Windows:
        train = context.train
        rng = np.random.default_rng(context.seed)
        ys = np.repeat(np.flatnonzero(context.budget_vector()), self.per_class)
        X = rng.normal(0, 0.1, (len(ys), train.n_timesteps, train.n_channels)).astype(np.float32)
        X[:, :, 4] += FAKE_LEVEL
        samples = np.array([f"sample-{i}" for i in range(len(ys))])
        return Windows(X, ys, np.full(len(ys), "synthetic"), train.label_names, train.channel_names,
                       train.fs_hz, meta={"sample": samples})


@pytest.fixture
def fake_vsmp(monkeypatch):
    monkeypatch.setattr(combined, "VsmpMethod", FakeVsmp)


def _context(dataset, budget: dict[str, int], seed: int = 0) -> FoldContext:
    train = dataset.windows()
    train = train.where_subjects(("1", "2", "3"))
    return FoldContext(dataset=dataset.info, fold="4", held_out_subject="4", train=train,
                       train_subjects=("1", "2", "3"), seed=seed, budget=budget, alpha=1.0,
                       protocol="lopo")


def test_registered_as_a_vsmp_method_with_the_spec_options():
    entry = REGISTRY["vsmp+classical"]
    assert entry.kind == "vsmp" and entry.generative and entry.unseen_classes
    spec = GenerationSpec(k=2, cache_dir="c")
    params = entry.params(spec)
    assert params["variant"] == "vsmp+classical" and params["k"] == 2
    built = make("vsmp+classical", **params)
    assert isinstance(built, VsmpClassicalMethod) and built.spec.k == 2 and built.spec.cache_dir == "c"


def test_vsmp_share_is_half_the_budget_rounded_up_at_most_what_was_made():
    assert vsmp_share(np.array([0, 1, 5, 10]), np.array([3, 3, 3, 3])).tolist() == [0, 1, 3, 3]


def test_the_budget_is_filled_half_by_vsmp_and_the_rest_by_augmenting_both(fake_vsmp, tiny_dataset):
    names = tiny_dataset.info.label_names
    budget = {names[0]: 8, names[1]: 3, names[3]: 40}
    out = VsmpClassicalMethod().generate(_context(tiny_dataset, budget))
    counts = np.bincount(out.y, minlength=len(names))
    assert counts.tolist() == [8, 3, 0, 40]
    part, origin = out.meta["part"], out.meta["origin"]
    for c, n in enumerate(counts):
        mine = out.y == c
        assert int((part[mine] == "vsmp").sum()) == min(FakeVsmp.per_class, (n + 1) // 2)
    augmented = part == "classical"
    # the augmentation draws from the real windows and the VSMP-IMU windows together
    assert {"real", "vsmp"} <= set(origin[augmented & (out.y == 3)].tolist())
    near_fake = np.linalg.norm(out.X[:, :, 3:6], axis=2).mean(axis=1) > FAKE_LEVEL / 2
    assert np.array_equal(near_fake, origin == "vsmp")  # provenance tells where each one came from
    assert all(s.startswith("sample-") for s in out.meta["origin_sample"][origin == "vsmp"])
    assert (out.meta["origin_index"][augmented & (origin == "real")] >= 0).all()
    assert set(out.meta["source"].tolist()) == {"vsmp+classical"}


def test_classical_fills_what_vsmp_could_not_make(fake_vsmp, monkeypatch, tiny_dataset):
    monkeypatch.setattr(FakeVsmp, "per_class", 1)
    names = tiny_dataset.info.label_names
    out = VsmpClassicalMethod().generate(_context(tiny_dataset, {names[2]: 10}))
    assert len(out) == 10 and int((out.meta["part"] == "vsmp").sum()) == 1


def test_same_seed_same_bytes(fake_vsmp, tiny_dataset):
    names = tiny_dataset.info.label_names
    budget = {n: 6 for n in names}
    a, b = (VsmpClassicalMethod().generate(_context(tiny_dataset, budget)) for _ in range(2))
    assert a.X.tobytes() == b.X.tobytes() and a.y.tolist() == b.y.tolist()
    c = VsmpClassicalMethod().generate(_context(tiny_dataset, budget, seed=1))
    assert a.X.tobytes() != c.X.tobytes()


def test_evaluate_runs_it(fake_vsmp, tiny_dataset):
    register_all()
    config = EvalConfig(dataset="tiny", methods=("real", "vsmp+classical"), folds=("2",), alpha=1.0,
                        backbone_params={"rf": {"n_estimators": 5, "n_jobs": 1}},
                        method_params={"vsmp+classical": REGISTRY["vsmp+classical"].params(GenerationSpec())})
    records = {r["method"]: r for r in Evaluation(config, tiny_dataset).run().records}
    assert records["vsmp+classical"]["n_synthetic"] == records["vsmp+classical"]["n_synthetic_requested"] > 0


def test_a_class_without_real_windows_is_made_from_vsmp_windows_only(fake_vsmp, tiny_dataset):
    """Under the unseen protocol a class has no real training window: its copies all start from
    VSMP-IMU windows of that class, never from another class's real windows."""
    names = tiny_dataset.info.label_names
    context = _context(tiny_dataset, {names[3]: 12, names[0]: 4})
    context = dataclasses.replace(context, train=context.train[context.train.y != 3])
    assert context.train.class_counts()[3] == 0
    out = VsmpClassicalMethod().generate(context)
    unseen = out.y == 3
    assert int(unseen.sum()) == 12
    assert set(out.meta["origin"][unseen].tolist()) == {"vsmp"}
    assert (np.linalg.norm(out.X[unseen][:, :, 3:6], axis=2).mean(axis=1) > FAKE_LEVEL / 2).all()
    copies = unseen & (out.meta["part"] == "classical")
    assert int(copies.sum()) == 12 - FakeVsmp.per_class
    assert all(s.startswith("sample-") for s in out.meta["origin_sample"][copies])
