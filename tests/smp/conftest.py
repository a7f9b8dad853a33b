"""Fixtures of the SMP tests: the library and small SMP builders."""

from __future__ import annotations

from pathlib import Path

import pytest

from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import SMP


@pytest.fixture(scope="session")
def library() -> ActivityLibrary:
    return ActivityLibrary.load()


@pytest.fixture
def jj(library) -> SMP:
    """The jumping-jacks library SMP (a fresh copy)."""
    return library.get("jumping_jacks").smp.model_copy(deep=True)


@pytest.fixture
def shared_responses():
    """Five raw responses for one jumping-jacks clip, in the shapes models really produce:
    clean JSON, JSON in prose and fences, misspelled keys and truncation, a refusal,
    and a sparse answer with a hallucinated object."""
    folder = Path(__file__).parent / "data" / "jumping_jacks_responses"
    return sorted(folder.glob("r*.txt"))
