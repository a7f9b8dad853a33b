"""Shared fixtures of the studies tests: the library, one small controllability run and a
small virtual UTD-MHAD folder."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from study_support import SMOKE_ACTIVITIES  # noqa: E402
from utd_fixture import write_utd_mhad  # noqa: E402

from vsmp_imu.smp.library import ActivityLibrary  # noqa: E402
from vsmp_imu.studies.control import ControlStudy  # noqa: E402


@pytest.fixture(scope="session")
def library() -> ActivityLibrary:
    return ActivityLibrary.load()


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory, library):
    """One seed, two activities: every control of the paper occurs (22 motions), HAPT grounding."""
    out = tmp_path_factory.mktemp("control")
    results = ControlStudy(seeds=[0], activities=SMOKE_ACTIVITIES, library=library).run(out)
    return out, results


@pytest.fixture(scope="session")
def utd_dir(tmp_path_factory):
    """UTD-MHAD files of four actions (wrist and thigh), three subjects, two trials each."""
    return write_utd_mhad(tmp_path_factory.mktemp("utd_mhad"))
