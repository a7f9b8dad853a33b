"""Fixtures of the reliability tests: a small real dataset in the generic format."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from reliability_support import make_small_dataset  # noqa: E402


@pytest.fixture(scope="session")
def small_dataset(tmp_path_factory) -> Path:
    """dataset.yaml of six HAPT subjects (walking, sitting, standing); SMPs in its smps/ folder."""
    return make_small_dataset(tmp_path_factory.mktemp("hapt_small"))
