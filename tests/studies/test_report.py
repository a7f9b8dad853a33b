"""The shared report helpers: JSON conversion, tables, atomic files, the result cache."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vsmp_imu.studies.report import (
    ResultCache,
    cache_key,
    fmt_num,
    fmt_pct,
    markdown_table,
    save_figure,
    to_jsonable,
    write_report,
)


def test_to_jsonable_turns_numpy_and_nan_into_plain_json():
    data = {"a": np.float32(1.5), "b": np.int64(3), "c": float("nan"), "d": np.array([1.0, np.inf]),
            "e": (np.bool_(True), None), 4: "key"}
    out = to_jsonable(data)
    assert out == {"a": 1.5, "b": 3, "c": None, "d": [1.0, None], "e": [True, None], "4": "key"}
    json.dumps(out, allow_nan=False)  # strict JSON


def test_formatters():
    assert fmt_pct(0.9166) == "91.7%" and fmt_pct(None) == "n/a" and fmt_pct(float("nan")) == "n/a"
    assert fmt_num(0.12345, 3) == "0.123" and fmt_num(np.float64(np.inf)) == "n/a"


def test_markdown_table():
    text = markdown_table(["name", "value"], [["a|b", 1], ["c", None]])
    assert text.splitlines() == ["| name | value |", "| :--- | ---: |", "| a\\|b | 1 |", "| c | n/a |"]
    with pytest.raises(ValueError):
        markdown_table(["one"], [["a", "b"]])


def test_write_report_writes_both_files(tmp_path):
    md, js = write_report(tmp_path / "out", "# Title\n\ntext", {"x": float("nan"), "y": [1, 2]})
    assert md.read_text() == "# Title\n\ntext\n"
    assert json.loads(js.read_text()) == {"x": None, "y": [1, 2]}
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["report.md", "results.json"]


def test_save_figure_is_atomic_and_closes(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    path = save_figure(fig, tmp_path / "f.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not plt.fignum_exists(fig.number)
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]


def test_result_cache_round_trip_and_damaged_entry(tmp_path):
    cache = ResultCache(tmp_path / "cache")
    key = cache_key(activity="a", seed=1, level="fast")
    assert key == cache_key(seed=1, level="fast", activity="a")  # order-free
    assert key != cache_key(activity="a", seed=2, level="fast")
    assert cache.get(key) is None
    cache.put(key, {"imu": np.arange(6.0).reshape(2, 3)}, {"value": 0.5, "window": None})
    arrays, meta = cache.get(key)
    np.testing.assert_array_equal(arrays["imu"], np.arange(6.0).reshape(2, 3))
    assert meta == {"value": 0.5, "window": None}
    (tmp_path / "cache" / f"{key}.npz").write_bytes(b"not an npz")
    assert cache.get(key) is None  # recomputed, not a crash
