"""Classical Aug: jitter, scaling, joint 3-D rotation per sensor, time warping."""

from __future__ import annotations

import numpy as np

from vsmp_imu.baselines.classical import (
    ClassicalAugmentation,
    rotate,
    sensor_triplets,
    time_warp,
)
from vsmp_imu.har.synthetic import FoldContext


def test_sensor_triplets_group_acc_and_gyro_per_location():
    names = (
        "wrist_acc_x",
        "wrist_acc_y",
        "wrist_acc_z",
        "wrist_gyr_x",
        "wrist_gyr_y",
        "wrist_gyr_z",
        "chest_acc_x",
        "chest_acc_y",
        "chest_acc_z",
        "heart_rate",
    )
    assert sensor_triplets(names) == [[0, 1, 2, 3, 4, 5], [6, 7, 8]]
    assert sensor_triplets(("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")) == [
        [0, 1, 2, 3, 4, 5]
    ]


def test_rotation_is_shared_by_acc_and_gyro_and_keeps_norms():
    rng = np.random.default_rng(0)
    x = np.zeros((20, 7))
    x[:, 0:3] = rng.normal(size=(20, 3))
    x[:, 3:6] = x[:, 0:3]  # gyro equal to acc: the same rotation keeps them equal
    x[:, 6] = 42.0
    out = rotate(x, [[0, 1, 2, 3, 4, 5]], 45.0, rng)
    assert np.allclose(out[:, 0:3], out[:, 3:6])
    assert np.allclose(np.linalg.norm(out[:, 0:3], axis=1), np.linalg.norm(x[:, 0:3], axis=1))
    assert not np.allclose(out[:, 0:3], x[:, 0:3])
    assert (out[:, 6] == 42.0).all()


def test_time_warp_keeps_length_and_constants():
    rng = np.random.default_rng(1)
    x = np.column_stack([np.full(50, 3.0), np.linspace(0, 1, 50)])
    out = time_warp(x, 0.3, 4, rng)
    assert out.shape == x.shape and np.allclose(out[:, 0], 3.0)
    assert np.all(np.diff(out[:, 1]) >= -1e-12)  # monotone warp of a ramp stays monotone
    assert out[0, 1] == 0 and out[-1, 1] == 1


def _context(dataset, seed=0, budget=None):
    windows = dataset.windows()
    train = windows.where_subjects(["1", "2"])
    return FoldContext(
        dataset=dataset.info,
        fold="6",
        held_out_subject="6",
        train=train,
        train_subjects=("1", "2"),
        seed=seed,
        budget=budget or {"class_0": 5, "class_3": 12},
        alpha=0.5,
        protocol="lopo",
    )


def test_generate_fills_the_budget_deterministically(tiny_dataset):
    source = ClassicalAugmentation()
    a = source.generate(_context(tiny_dataset))
    b = source.generate(_context(tiny_dataset))
    c = source.generate(_context(tiny_dataset, seed=1))
    assert a.class_counts().tolist() == [5, 0, 0, 12]
    assert np.array_equal(a.X, b.X) and not np.array_equal(a.X, c.X)
    assert a.X.shape[1:] == (40, 6) and np.isfinite(a.X).all()
    # provenance: each window names the real window it came from
    assert set(a.meta["origin_recording"]) <= {"s1", "s2"}
    assert (a.meta["source"] == "classical").all()
