"""Shared test fixtures."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

os.environ.setdefault("MPLBACKEND", "Agg")

REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DIR = REPO_ROOT.parent / "shared"
VIDEO_DIR = SHARED_DIR / "data" / "videos"


@pytest.fixture(scope="session", autouse=True)
def _private_cache(tmp_path_factory):
    """Parsed datasets are cached in a temporary folder, never in the user's home."""
    mp = pytest.MonkeyPatch()
    mp.setenv("VSMP_IMU_CACHE", str(tmp_path_factory.mktemp("vsmp-cache")))
    yield
    mp.undo()


@pytest.fixture
def cli():
    """Run `vsmp-imu ARGS...` in-process; returns (exit_code, stdout, stderr)."""
    from vsmp_imu.cli import app

    runner = CliRunner()

    def run(*args: str):
        from vsmp_imu.errors import VsmpError

        result = runner.invoke(app, [str(a) for a in args], catch_exceptions=True)
        code = result.exit_code
        err = result.stderr if hasattr(result, "stderr") else ""
        if isinstance(result.exception, VsmpError):
            code, err = 2, result.exception.render()
        elif result.exception is not None and not isinstance(result.exception, SystemExit):
            raise result.exception
        return code, result.stdout, err

    return run
