"""The output folder of each `vsmp-imu study NAME -o DIR`, taken before the study's work.

A study takes a new or empty folder, or one an earlier run of the same study wrote: it holds
RUN_FILE naming `vsmp-imu study NAME`, or (written before RUN_FILE was) only the names that
study writes. Any other folder is refused, so a study never writes its report.md,
results.json or figures over a user's files, nor into another study's folder
(`vsmp_imu.output_folder`).
"""

from __future__ import annotations

import re
from pathlib import Path

from vsmp_imu.output_folder import OutputFolder

RUN_FILE = "study_run.json"  # {"command": "vsmp-imu study NAME"}
COMMON = frozenset({"report.md", "results.json"})  # studies/report.py's write_report
# What each study writes at the top of its folder besides COMMON (FIGURE_NAME and the like of
# its report module; runs/: its evaluations; cache/: its generated samples or motions); a folder
# it wrote holds one of them.
OWN = {
    "control": ("cases.csv", "control_results.png", "cache"),
    "audit": ("clips.csv",),
    "case": ("case_study.png", "smp.json", "prompts.txt"),
    "ablation": ("ablation.png", "runs", "cache"),
    "granularity": ("granularity.png", "runs", "cache"),
    "realism": ("realism_pca.png", "realism_distance.png", "cache"),
}
# the case study's files per variant: variant_K.smp.json, variant_K.npz, variant_K_LOCATION.csv
PATTERNS = {"case": (re.compile(r"variant_\d+(\.smp\.json|\.npz|_.+\.csv)"),)}


def study_folder(study: str) -> OutputFolder:
    """The output folder of `vsmp-imu study STUDY`."""
    own = frozenset(OWN[study])
    return OutputFolder(f"vsmp-imu study {study}", RUN_FILE, names=COMMON | own, markers=own,
                        patterns=PATTERNS.get(study, ()))


def claim_study_folder(folder: Path, study: str) -> None:
    """Take `folder` for `vsmp-imu study STUDY` before its work, or refuse it (ConfigError)."""
    study_folder(study).claim(folder)
