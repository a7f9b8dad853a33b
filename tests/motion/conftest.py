"""Shared fixtures of the motion tests."""

from __future__ import annotations

import pytest

from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.library import ActivityLibrary


@pytest.fixture(scope="session")
def library() -> ActivityLibrary:
    return ActivityLibrary.load()


@pytest.fixture(scope="session")
def backend(library) -> ProceduralBackend:
    return ProceduralBackend(library)
