"""Label retention: the nearest-template classifier and its motion features."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.studies.retention import NearestTemplate, cut_windows, motion_signature


def test_nearest_template_blocks_weigh_the_same():
    # block 1 separates a/b by 100 units, block 2 by 1 unit: unscaled, block 1 would decide alone
    templates = np.array([[0.0, 0.0], [100.0, 1.0]])
    clf = NearestTemplate(n_blocks=2).fit(templates, ["a", "b"])
    assert clf.block_scale_ == pytest.approx([0.01, 1.0])
    assert clf.predict(np.array([[10.0, 1.0], [90.0, 0.0], [60.0, 1.0]])).tolist() == ["b", "a", "b"]


def test_nearest_template_rejects_bad_input():
    with pytest.raises(ValidationError):
        NearestTemplate().fit(np.zeros((2, 4)), ["a", "a"])
    with pytest.raises(ValidationError):
        NearestTemplate(n_blocks=2).fit(np.zeros((2, 3)), ["a", "b"])


def test_signature_is_body_size_free_and_finds_the_activity(library):
    backend = ProceduralBackend(library)
    names = ("two_arm_curl", "jogging_in_place", "right_arm_throw")
    feats, labels = [], []
    for name in names:
        for seed in (1000, 1001):
            feats.append(motion_signature(backend.generate(library.get(name).smp, seed=seed)))
            labels.append(name)
    clf = NearestTemplate().fit(np.array(feats), labels)
    curl = library.get("two_arm_curl").smp
    for attribute, level in (("tempo", "fast"), ("repetitions", 9), ("amplitude", "large")):
        motion = backend.generate(intervene(curl, attribute, level), seed=3)
        assert clf.predict(motion_signature(motion)[None])[0] == "two_arm_curl"
    motion = backend.generate(curl, seed=3)
    sig = motion_signature(motion)
    half = len(sig) // 2
    assert sig[half:].sum() == pytest.approx(1.0)  # movement shares
    bigger = type(motion)(motion.positions * 1.2, motion.rotations, motion.fps, motion.joint_names,
                          motion.parents, motion.meta)
    np.testing.assert_allclose(motion_signature(bigger), sig, atol=1e-9)


def test_cut_windows_pads_short_recordings():
    x = np.arange(30.0).reshape(15, 2)
    w = cut_windows(x, fs_hz=10.0, window_s=2.0)
    assert w.shape == (1, 20, 2) and (w[0, 15:] == x[-1]).all()
    w = cut_windows(np.zeros((50, 6)), fs_hz=10.0, window_s=2.0, overlap=0.5)
    assert w.shape == (4, 20, 6)
