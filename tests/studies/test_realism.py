"""The realism study: centroid distances by hand, a run on small UTD-MHAD files with a tiny
encoder (references, a noise control, outputs), CLI errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from study_support import assert_blocks_in_report, rebuild_study_tables

from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.studies.realism import (
    REFERENCE,
    SHUFFLED,
    RealismStudy,
    class_c2st,
    class_centroid_distances,
    window_embeddings,
)
from vsmp_imu.studies.realism_report import write_realism_outputs

PNG = b"\x89PNG\r\n\x1a\n"
TINY_ENCODER = {"n_filters": 8, "hidden": 16, "n_conv": 2, "batch_size": 16, "n_threads": 1}


def test_centroid_distance_by_hand():
    z_real = np.array([[0.0, 0.0], [2.0, 0.0], [10.0, 10.0], [10.0, 12.0]])
    y_real = np.array([0, 0, 1, 1])
    z_syn = np.array([[1.0, 3.0], [1.0, 5.0], [7.0, 7.0]])
    y_syn = np.array([0, 0, 2])  # class 2 has no real window: left out
    d = class_centroid_distances(z_syn, y_syn, z_real, y_real, n_classes=3)
    assert set(d) == {0}
    # centroids (1, 4) and (1, 0); real spread 1 (both points 1 from (1, 0)); synthetic spread 1
    assert d[0]["distance"] == pytest.approx(4.0)
    assert d[0]["real_spread"] == pytest.approx(1.0) and d[0]["coverage"] == pytest.approx(1.0)
    assert d[0]["relative_distance"] == pytest.approx(4.0)
    assert (d[0]["n_synthetic"], d[0]["n_real"]) == (2, 2)


def test_the_two_sample_test_tells_a_shifted_set_and_not_an_equal_one():
    rng = np.random.default_rng(0)
    channels = ("acc_x", "acc_y", "gyr_x")
    real = rng.normal(0.0, 1.0, (240, 50, 3)).astype(np.float32)
    y_real = np.repeat([0, 1], 120)
    same = rng.normal(0.0, 1.0, (240, 50, 3)).astype(np.float32)
    shifted = same.copy()
    shifted[:, :, 2] += 0.5  # gyr_x moved by half its spread
    y_set = np.repeat([0, 1, 2], 80)  # class 2 has no real window: left out
    equal = class_c2st(same, y_set, real, y_real, channels, n_classes=3)
    moved = class_c2st(shifted, y_set, real, y_real, channels, n_classes=3)
    assert set(equal) == set(moved) == {0, 1}
    assert equal[0]["n_per_side"] == 80
    for a in (0, 1):
        assert 0.3 < equal[a]["auc"] < 0.7, equal[a]
        assert moved[a]["auc"] > 0.95, moved[a]
        assert all(f.startswith("gyr_x q") for f in moved[a]["top_features"]), moved[a]
    assert class_c2st(same[:2], y_set[:2], real, y_real, channels, n_classes=3) == {}  # too few per side


@pytest.fixture(scope="module")
def realism(tmp_path_factory, utd_dir):
    out = tmp_path_factory.mktemp("realism")
    study = RealismStudy(dataset="utd_mhad", data_dir=utd_dir, fold="1", methods=("vsmp", "classical"),
                         epochs=4, patience=4, max_per_class=20, encoder_params=dict(TINY_ENCODER),
                         options=GenerationSpec(cache_dir=str(out / "cache")))
    results = study.run(out)
    paths = write_realism_outputs(results, out)
    return study, results, paths


def _row(results, method):
    return next(m for m in results.methods if m["method"] == method)


def test_rows_references_and_settings(realism):
    _, results, _ = realism
    assert [m["method"] for m in results.methods] == [REFERENCE, SHUFFLED, "vsmp", "classical"]
    assert results.skipped == {}
    assert results.encoder["layer"] == "conv" and results.encoder["params"]["n_filters"] == 8
    assert results.settings["fold"] == "1"
    for m in results.methods:
        assert m["classes"] == 4 and m["mean_distance"] > 0
        assert m["mean_distance"] == pytest.approx(np.mean([v["distance"] for v in m["per_class"].values()]))
        if m["method"] not in (REFERENCE, SHUFFLED):  # the synthetic budget is capped per class
            assert all(0 < v["n_synthetic"] <= 20 for v in m["per_class"].values())
        assert all(0.0 <= v["auc"] <= 1.0 and v["n_per_side"] >= 3 for v in m["c2st"].values())
        assert m["c2st_mean_auc"] == pytest.approx(np.mean([v["auc"] for v in m["c2st"].values()]))
    test = _row(results, REFERENCE)["per_class"]
    shuffled = _row(results, SHUFFLED)["per_class"]
    assert sum(v["n_synthetic"] for v in test.values()) == sum(v["n_synthetic"] for v in shuffled.values())


def test_held_out_real_windows_are_closer_than_shuffled_labels_or_noise(realism, utd_dir):
    from vsmp_imu.har.protocols import split_fold
    from vsmp_imu.smp.library import ActivityLibrary
    from vsmp_imu.studies.methods import load_study_dataset

    study, results, _ = realism
    real, shuffled = _row(results, REFERENCE), _row(results, SHUFFLED)
    assert real["mean_distance"] < shuffled["mean_distance"]
    # a noise set with the real windows' per-channel scale and random labels
    ds = load_study_dataset("utd_mhad", utd_dir, ActivityLibrary.load()).dataset
    split = split_fold(ds.windows(), "1", "lopo", 0)
    rng = np.random.default_rng(0)
    mean, std = split.fit.X.mean(axis=(0, 1)), split.fit.X.std(axis=(0, 1))
    noise = (mean + std * rng.standard_normal((40, *split.fit.X.shape[1:]))).astype(np.float32)
    y_noise = rng.choice(np.unique(split.fit.y), 40)
    d_noise = class_centroid_distances(study.embed(noise), y_noise, study.embed(split.fit.X), split.fit.y,
                                       ds.info.n_classes)
    assert real["mean_distance"] < np.mean([v["distance"] for v in d_noise.values()])


def test_embeddings_of_both_layers(realism):
    study, _, _ = realism
    X = np.zeros((3, 100, 6), np.float32)
    assert study.embed(X).shape == (3, 8 * 6)  # conv features, averaged over time
    lstm = window_embeddings(study.encoder_, X, "lstm")
    assert lstm.shape == (3, 16) and np.allclose(lstm, study.encoder_.embed(X))


def test_outputs_are_written(realism):
    _, results, paths = realism
    for key in ("pca", "distance"):
        assert paths[key].read_bytes()[:8] == PNG
    data = json.loads(paths["results"].read_text())
    assert [m["method"] for m in data["methods"]] == [m["method"] for m in results.methods]
    assert len(data["pca"]["explained_variance_ratio"]) == 2
    assert all(math.isfinite(m["mean_distance"]) for m in data["methods"])
    report = paths["report"].read_text()
    for text in ("## Class-wise centroid distance", "Real, held-out, labels shuffled", "VSMP-IMU",
                 "final convolutional layer", "## Two-sample test on the RF's features",
                 "## Deviations from the paper"):
        assert text in report


@pytest.mark.parametrize("args, field", [
    (("--methods", "real"), "--methods"),
    (("--methods", "vsmp,gan"), "--methods"),
    (("--layer", "pool"), "--layer"),
    (("--epochs", "0"), "--epochs"),
    (("--encoder-windows", "-3"), "--encoder-windows"),
    (("--alpha", "0"), "--alpha"),
    (("--fold", "99"), "--fold"),
])
def test_bad_input_gives_a_clean_message(cli, tmp_path, args, field):
    code, _, err = cli("study", "realism", "-o", tmp_path / "out", *args)
    assert code == 2
    assert field in err


def test_the_study_record_rebuilds_the_distance_table(realism, tmp_path):
    _, _, paths = realism
    out = paths["report"].parent
    blocks = rebuild_study_tables(out, "vsmp-imu study realism -o out -d utd_mhad --fold 1",
                                  {"realism:main": "realism:distances", "realism:classes": "realism:classes",
                                   "realism:c2st": "realism:c2st"},
                                  tmp_path)
    assert_blocks_in_report(blocks, paths["report"].read_text())
    assert "| Real, held-out subject |" in blocks["realism:main"]


def test_the_command_prints_each_sets_distance_and_two_sample_auc(cli, tmp_path, utd_dir):
    code, out, err = cli("study", "realism", "-o", tmp_path / "out", "-d", "utd_mhad", "--data-dir", utd_dir,
                         "--fold", "1", "--methods", "classical", "--epochs", "1", "--filters", "8",
                         "--hidden", "16", "--max-per-class", "10")
    assert code == 0, err
    lines = [line for line in out.splitlines() if "two-sample AUC" in line]
    assert [line.split(":")[0] for line in lines] == [REFERENCE, SHUFFLED, "classical"]
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    auc = next(m for m in data["methods"] if m["method"] == "classical")["c2st_mean_auc"]
    assert f"two-sample AUC {auc:.2f}" in lines[-1]
