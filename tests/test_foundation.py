"""Errors, atomic writes and the CLI's handling of user mistakes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from vsmp_imu.errors import ValidationError, VsmpError
from vsmp_imu.io import atomic_path, read_structured, write_json


def test_error_message_names_file_field_and_allowed():
    err = ValidationError("bad value 'zoom'", file="a.json", field="execution_attributes.tempo",
                          allowed="slow, medium, fast, unknown")
    text = err.render()
    assert text.startswith("a.json: field 'execution_attributes.tempo': bad value 'zoom'.")
    assert text.endswith("Allowed: slow, medium, fast, unknown.")
    assert isinstance(err, VsmpError)


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.json"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("partial")
        raise RuntimeError("crash")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_uses_the_usual_file_mode(tmp_path):
    import os

    mask = os.umask(0o022)
    try:
        path = write_json(tmp_path / "m.json", {"a": 1})
    finally:
        os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o644


def test_atomic_write_replaces_whole_file(tmp_path):
    target = tmp_path / "out.json"
    write_json(target, {"a": 1})
    write_json(target, {"b": 2})
    assert read_structured(target) == {"b": 2}
    assert [p.name for p in tmp_path.iterdir()] == ["out.json"]


def test_console_script_exits_2_with_one_paragraph(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"activity_label": "x"}')
    proc = subprocess.run(
        [sys.executable, "-c", "from vsmp_imu.cli import main; main()", "smp", "validate", str(bad)],
        capture_output=True, text=True,
    )
    assert proc.returncode == 2
    assert str(bad) in proc.stderr
    assert "motion_primitives" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_missing_file_is_exit_2(cli, tmp_path):
    code, _, err = cli("smp", "validate", tmp_path / "nope.json")
    assert code == 2
    assert "file not found" in err


@pytest.mark.parametrize("name,text,where", [
    ("spec.yaml", "name: a\nfs_hz: 50\nfs_hz: 25\n", "key 'fs_hz' appears twice (lines 2 and 3)"),
    ("spec.yaml", "a:\n  b: 1\n  c: 2\n  b: 3\n", "key 'b' appears twice (lines 2 and 4)"),
    ("spec.json", '{"a": 1, "b": {"c": 2, "c": 3}}', "key 'c' appears twice"),
])
def test_a_key_written_twice_is_refused(tmp_path, name, text, where):
    """The last of two values would win silently (fs_hz: 50 then 25 halves every duration)."""
    from vsmp_imu.errors import InputFileError

    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputFileError) as err:
        read_structured(path)
    assert where in err.value.render() and name in err.value.render()


def test_yaml_merge_keys_and_equal_values_in_lists_still_read(tmp_path):
    path = tmp_path / "spec.yaml"
    path.write_text("base: &b {x: 1, y: 2}\nother:\n  <<: *b\n  y: 3\nlist: [a, a]\n")
    assert read_structured(path) == {"base": {"x": 1, "y": 2}, "other": {"x": 1, "y": 3}, "list": ["a", "a"]}
