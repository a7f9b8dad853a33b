"""Paths and constants shared by the studies tests."""

from __future__ import annotations

from pathlib import Path

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
AUDIT_DIR = FIXTURES / "audit"
UTD_DIR = FIXTURES / "datasets" / "utd_mhad"
VIDEO_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "videos"
SMOKE_ACTIVITIES = ("two_arm_curl", "two_hand_push")
