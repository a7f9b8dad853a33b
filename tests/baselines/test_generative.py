"""IMUGPT 2.0-style and IMUTube-style baselines on the shared pipeline."""

from __future__ import annotations

import json
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
    parse_descriptions,
    unusable_descriptions,
)
from vsmp_imu.errors import ConfigError, VsmpError
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.synthetic import FoldContext, synthetic_budget
from vsmp_imu.smp.library import ActivityLibrary

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
    assert server.requests[0]["headers"]["accept-encoding"] == "identity"  # the bounded transport


def test_parse_descriptions():
    assert parse_descriptions('{"descriptions": [" A person walks. ", "", 3, {"x": 1}, "Strolls."]}') == (
        ["A person walks.", "Strolls."], None)
    assert parse_descriptions('["A person walks."]') == (["A person walks."], None)
    for text in ("", "I'm sorry, but I can't help with that.", '{"descriptions": []}', '"just a string"',
                 '{"descriptions": "walk"}', '{"refusal": "no"}', "null", "[" * 100_000, '{"descriptions": [1, " "]}'):
        items, why = parse_descriptions(text)
        assert items == [] and why, text
        assert unusable_descriptions(text) == why


USABLE = '{"descriptions": ["A person walks briskly."]}'


@pytest.mark.parametrize("bad", ["", "I'm sorry, but I can't help with that.", '{"descriptions": []}',
                                 '{"descriptions": "walk"}'])
def test_an_unusable_description_answer_is_not_cached_and_asked_again(tmp_path, bad):
    from vsmp_imu.extract.client import VLMClient

    with ChatServer([Reply(200, bad), Reply(200, USABLE)]) as server:
        client = VLMClient(server.url, "describer", api_key="test", cache_dir=tmp_path, sleep=lambda s: None)
        with pytest.raises(VsmpError, match="not the expected JSON .*not cached"):
            llm_descriptions(client, "walking", 1)
        assert not list(tmp_path.rglob("??/*.json"))
        assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]  # asked again
        assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]  # now cached
        assert len(server.requests) == 2
    assert len(list(tmp_path.rglob("??/*.json"))) == 1


def test_a_refusal_field_is_not_cached(tmp_path):
    """A model that refuses through `message.refusal` (content null) gets asked again."""
    import json

    from vsmp_imu.extract.client import VLMClient

    envelope = {"choices": [{"index": 0, "message": {"role": "assistant", "content": None,
                                                     "refusal": "I can't help with that."}}]}
    with ChatServer([Reply(200, raw_body=json.dumps(envelope)), Reply(200, USABLE)]) as server:
        client = VLMClient(server.url, "describer", api_key="test", cache_dir=tmp_path, sleep=lambda s: None)
        with pytest.raises(VsmpError, match="describer|description model"):
            llm_descriptions(client, "walking", 1)
        assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]
        assert len(server.requests) == 2


@pytest.mark.parametrize("damage", [b"\xff\xfe", b"{trunc", b'{"format": 1}', b"[" * 100_000])
def test_a_damaged_description_cache_entry_is_a_miss_with_a_warning(tmp_path, caplog, damage):
    from vsmp_imu.extract.client import VLMClient

    with ChatServer([Reply(200, USABLE), Reply(200, USABLE)]) as server:
        client = VLMClient(server.url, "describer", api_key="test", cache_dir=tmp_path, sleep=lambda s: None)
        assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]
        (entry,) = tmp_path.rglob("??/*.json")
        entry.write_bytes(damage)
        with caplog.at_level("WARNING"):
            assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]
        assert len(server.requests) == 2
    assert "cache entry not used, asked again" in caplog.text
    assert llm_descriptions(client, "walking", 1) == ["A person walks briskly."]  # the entry was replaced


@pytest.mark.parametrize("cache_dir,where", [(None, "cache/vlm"), ("cache/samples", "cache/vlm"),
                                             ("mine", "mine/describer")])
def test_the_describer_cache_is_never_the_current_folder(context, tmp_path, monkeypatch, cache_dir, where):
    """Without a cache_dir of its own (none, or the project's samples folder, which is pruned
    and cleared), the describer's answers go to the `vlm` cache folder."""
    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)
    seen = []
    monkeypatch.setattr("vsmp_imu.baselines.generative.llm_descriptions",
                        lambda client, activity, n: seen.append(client.cache_dir) or [f"A person does {activity}."])
    method = ImuGptMethod(n_descriptions=1, describer_url="http://127.0.0.1:9/v1",
                          cache_dir=None if cache_dir is None else str(tmp_path / cache_dir))
    method._bases(context, ActivityLibrary.load())
    assert seen and all(Path(d) == tmp_path / where for d in seen)
    assert not (tmp_path / "describer").exists()


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


GENERIC = Path(__file__).resolve().parents[1] / "fixtures" / "datasets" / "generic" / "dataset.yaml"


def test_evaluate_asks_the_describer_its_options_name_and_records_it(cli, tmp_path, monkeypatch):
    """`evaluate --describer-url/--describer-model` (the describer was settable from Python only):
    the imugpt descriptions come from that endpoint and model, the run's settings and results
    name it, and a rerun into the folder without it is refused (its windows would differ)."""
    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "cache"))
    walk = json.dumps({"descriptions": ["A person walks briskly.", "A person walks slowly with small steps."]})
    sit = json.dumps({"descriptions": ["A person sits down on a chair.", "A person sits still, relaxed."]})
    out = tmp_path / "out"
    args = ("evaluate", "--dataset", GENERIC, "--methods", "real,imugpt", "--folds", "p1", "--jobs", "1", "-o", out)
    with ChatServer([Reply(200, walk), Reply(200, sit)]) as server:
        code, stdout, err = cli(*args, "--describer-url", server.url, "--describer-model", "writer")
    assert code == 0, stdout + err
    assert [r["body"]["model"] for r in server.requests] == ["writer", "writer"]  # one per class, then cached
    prompts = [r["body"]["messages"][0]["content"] for r in server.requests]
    assert any("'walk" in p for p in prompts) and any("'sit" in p for p in prompts)
    describer = {"describer_url": server.url, "describer_model": "writer"}
    settings = json.loads((out / "evaluate.json").read_text())["methods"]
    assert describer.items() <= settings["imugpt"].items() and "describer_url" not in settings["real"]
    params = json.loads((out / "results.json").read_text())["config"]["method_params"]
    assert describer.items() <= params["imugpt"].items()
    code, _, err = cli(*args)  # the templated descriptions: other windows, other records
    assert code == 2 and "imugpt's describer_url" in err


@pytest.mark.parametrize("options,field", [
    (("--describer-url", "localhost:8000/v1"), "--describer-url"),
    (("--describer-url", "ftp://host/v1"), "--describer-url"),
    (("--describer-url", "http://"), "--describer-url"),
    (("--describer-url", "http://host /v1"), "--describer-url"),
    (("--describer-url", "http://host:port/v1"), "--describer-url"),
    (("--describer-model", "writer"), "--describer-model"),  # a model of no endpoint
])
def test_evaluate_refuses_a_describer_that_names_no_endpoint_before_any_work(cli, tmp_path, options, field):
    code, _, err = cli("evaluate", "--dataset", tmp_path / "missing.yaml", "--methods", "real,imugpt", *options,
                       "-o", tmp_path / "out")
    assert code == 2 and f"field '{field}'" in err and "missing.yaml" not in err


def test_evaluate_refuses_a_describer_no_chosen_method_asks(cli, tmp_path):
    code, _, err = cli("evaluate", "--dataset", "hapt12", "--methods", "real,vsmp", "--describer-url",
                       "http://localhost:8000/v1", "-o", tmp_path / "out")
    assert code == 2 and "field '--describer-url'" in err and "imugpt" in err
