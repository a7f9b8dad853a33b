"""`kind: curve`: a metric against the label budget, joined from several record sets, drawn as a
PNG by `vsmp-imu report --write` and checked through the table of what it plots."""

from __future__ import annotations

from pathlib import Path

import pytest

from vsmp_imu.har.curves import figure_path
from vsmp_imu.har.published import Publication, TableSpec

LABELS = ("WALKING", "SIT_TO_LIE")


def _record(method: str, budget: float, fold: int, f1: float) -> dict:
    return {"dataset": "hapt12", "protocol": "low-resource", "budget": budget, "backbone": "rf",
            "method": method, "fold": str(fold), "seed": 0, "macro_f1": f1, "accuracy": f1,
            "group_macro_f1": {"transitions": f1 - 0.2}, "head_macro_f1": None, "tail_macro_f1": None,
            "per_class_f1": {"WALKING": f1, "SIT_TO_LIE": f1}, "confusion": [[1, 0], [0, 1]],
            "n_synthetic": 0, "n_synthetic_requested": 0, "n_train_real": 10}


CATALOGUE = """
tables:
  - id: curve:rf
    kind: curve
    records: low
    extra_records: [real_curve]
    backbone: rf
    budgets: [1, 5, 100]
    methods: [real, vsmp]
    metrics:
      - {label: all classes, metric: macro_f1}
"""

DOC = "# Results\n\n<!-- report:curve:rf -->\n<!-- /report -->\n"


@pytest.fixture()
def repo(report_repo, import_records) -> Path:
    root = report_repo(CATALOGUE, {"docs/results.md": DOC, "README.md": DOC})
    low = [_record(m, b, f, 0.5 + 0.1 * (m == "vsmp") + 0.01 * f) for m in ("real", "vsmp") for b in (1.0, 5.0)
           for f in (1, 2)]
    # the curve's 5 % Real-only is also in this set, with other figures: the first set wins
    curve = [_record("real", b, f, 0.9 if b == 5.0 else 0.8) for b in (5.0, 100.0) for f in (1, 2)]
    import_records(root, "low", low, LABELS)
    import_records(root, "real_curve", curve, LABELS)
    return root


def test_a_curve_takes_each_point_from_the_first_set_that_has_it(repo):
    text = Publication(repo).render("curve:rf", repo / "docs" / "results.md")
    assert "![all classes against the label budget](img/curve-rf.png)" in text
    assert "| 1 % | 51.50 (2) | 61.50 (2) |" in text
    assert "| 5 % | 51.50 (2) | 61.50 (2) |" in text  # from `low`, not real_curve's 90
    assert "| 100 % | 80.00 (2) | – |" in text
    assert "`results/low/` from `vsmp-imu evaluate -o low` at commit abc1234" in text
    assert "`results/real_curve/` from `vsmp-imu evaluate -o real_curve`" in text


def test_the_link_is_relative_to_the_document(repo):
    assert "](docs/img/curve-rf.png)" in Publication(repo).render("curve:rf", repo / "README.md")


def test_write_draws_the_figure_and_check_asks_for_it(repo):
    outcome = Publication(repo).check()
    assert any("figure 'curve:rf' not drawn" in d for d in outcome.differing)
    written = Publication(repo).check(write=True).written
    png = repo / figure_path("curve:rf")
    assert png in written and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    again = Publication(repo).check(write=True)
    assert again.written == [] and Publication(repo).check().differing == []  # same records, same bytes


def test_a_changed_record_shows_in_the_check(repo):
    Publication(repo).check(write=True)
    path = repo / "results" / "real_curve" / "records.jsonl"
    path.write_text(path.read_text().replace('"macro_f1": 0.8', '"macro_f1": 0.7'))
    assert sorted(Publication(repo).check().differing) == ["README.md: table 'curve:rf'",
                                                          "docs/results.md: table 'curve:rf'"]


def test_a_curve_spec_needs_its_axes():
    with pytest.raises(ValueError, match="curve needs"):
        TableSpec(id="x:c", records="a", kind="curve", methods=["real"],
                  metrics=[{"label": "all", "metric": "macro_f1"}], budgets=[1, 5])
    with pytest.raises(ValueError, match="extra_records"):
        TableSpec(id="x:g", records="a", kind="groups", extra_records=["b"], methods=["real"],
                  metrics=[{"label": "all", "metric": "macro_f1"}])
