"""The sample cache key's code part: which source changes invalidate cached samples."""

from pathlib import Path

from vsmp_imu.pipeline.sample import code_fingerprint, source_fingerprint


def _package(root: Path) -> Path:
    for rel, text in {"seeding.py": "SEED = 1\n", "cli/main.py": "X = 1\n", "motion/gait.py": "STEP = 1\n",
                      "smp/library/walk.yaml": "label: walk\n", "har/report.py": "R = 1\n",
                      "smp/activities/walking.yaml": "name: walking\n"}.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    return root


def test_a_top_level_module_or_a_room_changes_the_fingerprint(tmp_path):
    root = _package(tmp_path / "pkg")
    before = source_fingerprint(root)
    for rel in ("seeding.py", "motion/gait.py", "smp/library/walk.yaml"):
        path = root / rel
        text = path.read_text()
        path.write_text(text + "# changed\n")
        assert source_fingerprint(root) != before, rel
        path.write_text(text)
        assert source_fingerprint(root) == before


def test_code_a_sample_never_runs_leaves_the_fingerprint(tmp_path):
    root = _package(tmp_path / "pkg")
    before = source_fingerprint(root)
    # activity files are data: a sample's key holds its own entry's digest (test_sample_key.py)
    for rel in ("cli/main.py", "har/report.py", "smp/activities/walking.yaml"):
        (root / rel).write_text("CHANGED = 2\n")
    (root / "notes.txt").write_text("not code\n")
    assert source_fingerprint(root) == before


def test_the_installed_package_has_one_fingerprint():
    import vsmp_imu

    root = Path(vsmp_imu.__file__).resolve().parent
    assert code_fingerprint() == source_fingerprint(root)
    assert len(code_fingerprint()) == 16
