"""IMUGPT 2.0-style and IMUTube-style baselines on the shared pipeline."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.baselines.generative import (
    ImuGptMethod,
    ImuTubeMethod,
    llm_descriptions,
    offline_descriptions,
)
from vsmp_imu.errors import ConfigError
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.synthetic import FoldContext, synthetic_budget

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "extract"))
from extract_support import VIDEO_DIR  # noqa: E402
from vlm_server import ChatServer, Reply  # noqa: E402


@pytest.fixture(scope="module")
def context():
    ds = load_dataset("hapt12")
    train = ds.windows().where_subjects(["2", "3", "4"])
    budget = synthetic_budget(train.class_counts(), 0.05)
    names = train.label_names
    return FoldContext(dataset=ds.info, fold="1", held_out_subject="1", train=train,
                       train_subjects=("2", "3", "4"), seed=0,
                       budget={names[i]: int(n) for i, n in enumerate(budget) if n},
                       alpha=0.05, protocol="lopo")


def test_offline_descriptions_are_distinct_seeded_and_built_from_captions():
    caps = ("A person walks.", "Someone walks forward.")
    a = offline_descriptions(caps, 6, seed=0, key="WALKING")
    assert len(a) == len(set(a)) == 6
    assert a == offline_descriptions(caps, 6, seed=0, key="WALKING")
    assert a != offline_descriptions(caps, 6, seed=1, key="WALKING")
    assert all(d.startswith(("A person walks", "Someone walks forward")) for d in a)


def test_llm_descriptions_through_a_chat_completions_server(tmp_path):
    from vsmp_imu.extract.client import VLMClient

    answer = '```json\n{"descriptions": ["A person walks briskly.", "A person strolls slowly."]}\n```'
    with ChatServer([Reply(200, answer)]) as server:
        client = VLMClient(server.url, "describer", api_key="test", cache_dir=tmp_path, sleep=lambda s: None)
        got = llm_descriptions(client, "walking", 2)
        again = llm_descriptions(client, "walking", 2)  # served from the cache
        assert len(server.requests) == 1
    assert got == again == ["A person walks briskly.", "A person strolls slowly."]
    assert "walking" in server.requests[0]["body"]["messages"][0]["content"]


def test_imugpt_windows_come_from_prompts_without_smp_or_calibration(context, tmp_path):
    method = ImuGptMethod(n_descriptions=4, cache_dir=str(tmp_path))
    windows = method.generate(context)
    assert len(windows) > 0 and np.isfinite(windows.X).all()
    assert (windows.class_counts() <= context.budget_vector()).all()
    records = [r for r in method.last_output_.records if r.windowed]
    assert all(r.provenance.smp_id is None for r in records)
    assert all(r.provenance.source.startswith("description:") for r in records)
    assert all(r.provenance.locations["waist"].eta is None for r in records)
    assert all({v.filter for v in r.verdicts} <= {"motion", "imu", "redundancy"} for r in records)


def test_imutube_needs_clips(context):
    with pytest.raises(ConfigError, match="video"):
        ImuTubeMethod().generate(context)


@pytest.mark.video
def test_imutube_from_a_real_clip(context, tmp_path):
    pytest.importorskip("mediapipe")
    clip = VIDEO_DIR / "carphone_pristine.mp4"
    if not clip.exists():
        pytest.skip(f"{clip} is not available")
    (tmp_path / "pool" / "sitting").mkdir(parents=True)
    shutil.copy(clip, tmp_path / "pool" / "sitting" / clip.name)
    method = ImuTubeMethod(source=f"video:{tmp_path / 'pool'}", cache_dir=str(tmp_path / "cache"))
    windows = method.generate(context)
    assert set(np.unique(windows.y)) <= {context.train.label_names.index("SITTING")}
    assert (tmp_path / "pool" / "sitting" / (clip.name + ".pose.npz")).exists()
    records = [r for r in method.last_output_.records if r.windowed]
    assert records and all(r.provenance.source == f"video:{clip.name}" for r in records)
