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


def rebuild_study_tables(out: Path, command: str, views: dict[str, str], root: Path) -> dict[str, str]:
    """Import the study output folder `out` as record set `study` under `root/results/`, declare one
    table per view (table id `study:NAME` -> view) in a catalogue, place them in `root/README.md`,
    rebuild with `report --write` and check with `report --check`; returns the rebuilt blocks."""
    import re

    code, _, err = invoke("report", "import", out, "--name", "study", "--command", command,
                          "--commit", "0" * 40, "--root", root)
    assert code == 0, err
    tables = "".join(f"  - id: {table_id}\n    records: study\n    kind: study\n    view: {view}\n"
                     for table_id, view in views.items())
    (root / "results" / "tables.yaml").write_text("tables:\n" + tables)
    (root / "README.md").write_text("".join(f"<!-- report:{t} -->\nold\n<!-- /report -->\n\n" for t in views))
    code, _, err = invoke("report", "--root", root, "--write")
    assert code == 0, err
    code, stdout, err = invoke("report", "--root", root, "--check")
    assert code == 0, stdout + err
    text = (root / "README.md").read_text()
    return {m[1]: m[2] for m in re.finditer(r"<!-- report:(\S+) -->\n(.*?)<!-- /report -->", text, re.S)}


def assert_blocks_in_report(blocks: dict[str, str], report: str) -> None:
    """Every paragraph of every rebuilt block (less its source line) is printed as is in report.md."""
    for table_id, block in blocks.items():
        body = block.split("\n\nRecords: ")[0]
        for paragraph in body.split("\n\n"):
            assert paragraph in report, f"{table_id}: {paragraph[:80]}"
