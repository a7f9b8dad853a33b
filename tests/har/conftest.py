"""Fixtures of the har tests: a private dataset cache, fixture folders, a tiny dataset."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "datasets"


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    return FIXTURES


@pytest.fixture(scope="session")
def hapt_windows():
    from vsmp_imu.har.datasets.hapt import HAPT

    return HAPT().windows()


class TinyDataset:
    """Factory of a small in-memory dataset whose channel 0 encodes the subject (x 1000),
    so anything that sees windows can tell which subjects it saw."""

    @staticmethod
    def make(
        n_subjects: int = 6,
        n_classes: int = 4,
        seconds_per_class: float = 6.0,
        fs_hz: float = 20.0,
        seed: int = 0,
    ):
        from vsmp_imu.har.dataset import (
            DatasetInfo,
            HarDataset,
            Recording,
            SensorLocation,
            imu_channel_names,
        )

        rng = np.random.default_rng(seed)
        labels = tuple(f"class_{c}" for c in range(n_classes))

        class Tiny(HarDataset):
            def __init__(self):
                super().__init__()
                self.info = DatasetInfo(
                    name="tiny",
                    fs_hz=fs_hz,
                    label_names=labels,
                    channel_names=imu_channel_names(None),
                    locations=(
                        SensorLocation(
                            "waist",
                            imu_channel_names(None),
                            ("up", "forward", "left"),
                            True,
                            "m/s^2",
                            "rad/s",
                            "documented",
                        ),
                    ),
                )

            def _load(self):
                recs = []
                for s in range(1, n_subjects + 1):
                    n = int(seconds_per_class * fs_hz)
                    # class c repeated (c + 1) times: an imbalanced dataset
                    order = [c for c in range(n_classes) for _ in range(c + 1)]
                    lab = np.repeat(order, n)
                    t = np.arange(len(lab)) / fs_hz
                    data = rng.normal(0, 0.3, (len(lab), 6))
                    data[:, 0] = 1000.0 * s  # subject fingerprint
                    data[:, 1] += np.sin(2 * np.pi * (lab + 1) * t) * 2 + lab
                    data[:, 3] += lab * 0.5
                    recs.append(Recording(f"s{s}", str(s), "1", data, lab))
                return recs

        return Tiny()


@pytest.fixture
def tiny_dataset():
    return TinyDataset.make()


@pytest.fixture
def tiny_factory():
    """`TinyDataset.make`: for tests that need several independent copies of the tiny dataset."""
    return TinyDataset.make


@pytest.fixture
def report_repo(tmp_path):
    """A function making a repository skeleton for `vsmp-imu report`: results/tables.yaml from
    `catalogue` and each of `docs` ({relative path: text}); returns its root."""

    def make(catalogue: str, docs: dict[str, str]) -> Path:
        root = tmp_path / "repo"
        (root / "results").mkdir(parents=True)
        (root / "results" / "tables.yaml").write_text(catalogue)
        for rel, text in docs.items():
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).write_text(text)
        return root

    return make


@pytest.fixture()
def import_records(tmp_path):
    """A function importing evaluation records (their classes `labels`) as record set `name` of
    a repository skeleton's results/, at commit abc1234."""

    def run(root: Path, name: str, records: list[dict], labels: tuple[str, ...]) -> None:
        import json

        from vsmp_imu.har.records import import_run

        folder = tmp_path / f"run_{name}"
        folder.mkdir()
        (folder / "results.json").write_text(json.dumps({"config": {}, "label_names": list(labels),
                                                         "records": records}))
        import_run(folder, name, f"vsmp-imu evaluate -o {name}", root / "results", code_commit="abc1234")

    return run
