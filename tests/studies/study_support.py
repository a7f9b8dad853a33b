"""Paths and constants shared by the studies tests."""

from __future__ import annotations

from pathlib import Path

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
AUDIT_DIR = FIXTURES / "audit"
UTD_DIR = FIXTURES / "datasets" / "utd_mhad"
VIDEO_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "videos"
SMOKE_ACTIVITIES = ("two_arm_curl", "two_hand_push")


def invoke(*args):
    """`vsmp-imu ARGS...` in-process, as the `cli` fixture runs it, for module-scoped runs:
    (exit code, stdout, message of a VsmpError)."""
    from typer.testing import CliRunner

    from vsmp_imu.cli import app
    from vsmp_imu.errors import VsmpError

    result = CliRunner().invoke(app, [str(a) for a in args], catch_exceptions=True)
    if isinstance(result.exception, VsmpError):
        return 2, result.stdout, result.exception.render()
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    return result.exit_code, result.stdout, ""
