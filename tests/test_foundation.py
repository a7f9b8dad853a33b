"""Errors, atomic writes and the CLI's handling of user mistakes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from vsmp_imu.errors import ValidationError, VsmpError, some_of
from vsmp_imu.io import atomic_path, read_structured, write_json


def test_error_message_names_file_field_and_allowed():
    err = ValidationError("bad value 'zoom'", file="a.json", field="execution_attributes.tempo",
                          allowed="slow, medium, fast, unknown")
    text = err.render()
    assert text.startswith("a.json: field 'execution_attributes.tempo': bad value 'zoom'.")
    assert text.endswith("Allowed: slow, medium, fast, unknown.")
    assert isinstance(err, VsmpError)


def test_a_long_list_in_a_message_is_cut_to_its_first_items():
    assert some_of(["a", "b"]) == "a, b"
    assert some_of(range(5)) == "0, 1, 2, 3, 4"
    assert some_of(range(3000), 3) == "0, 1, 2 and 2997 more"


def test_a_skeleton_of_thousands_of_joints_is_named_in_one_short_paragraph():
    import numpy as np

    from vsmp_imu.motion.motion import Motion

    n = 3000
    rotations = np.zeros((2, n, 4))
    rotations[..., 3] = 1.0
    motion = Motion(np.zeros((2, n, 3)), rotations, 30.0, tuple(f"j{i}" for i in range(n)),
                    (-1, *range(n - 1)))
    with pytest.raises(ValidationError) as caught:
        motion.joint_index("pelvis")
    assert caught.value.render().endswith("Allowed: " + ", ".join(f"j{i}" for i in range(30)) + " and 2970 more.")


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.json"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("partial")
        raise RuntimeError("crash")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []


def test_a_stop_right_after_the_temporary_is_made_leaves_nothing(tmp_path, monkeypatch):
    """Ctrl-C or SIGTERM (`vsmp_imu.cli.Interrupted`) landing between mkstemp and the cleanup's
    `try` left the hidden temporary behind (a `motion render` stopped as it began)."""
    import os

    close = os.close

    def stopped(fd):
        close(fd)
        monkeypatch.undo()  # the stop comes once
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "close", stopped)
    with pytest.raises(KeyboardInterrupt), atomic_path(tmp_path / "out.gif"):
        pass
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_stop_while_the_temporary_is_created_leaves_nothing(tmp_path, monkeypatch, sig):
    """A signal that arrives inside mkstemp, after the file exists and before its name is returned
    (a `motion render` stopped as it began, under load), waits until the cleanup is armed."""
    import os
    import signal
    import tempfile

    if not hasattr(signal, "pthread_sigmask"):
        pytest.skip("no pthread_sigmask on this platform")
    number = getattr(signal, sig)
    previous = signal.signal(number, signal.default_int_handler)  # the stop raises KeyboardInterrupt
    make = tempfile.mkstemp

    def made_then_stopped(*args, **kwargs):
        out = make(*args, **kwargs)
        os.kill(os.getpid(), number)
        for _ in range(1000):  # bytecodes at which an unheld signal's handler runs
            pass
        return out

    monkeypatch.setattr(tempfile, "mkstemp", made_then_stopped)
    try:
        with pytest.raises(KeyboardInterrupt), atomic_path(tmp_path / "out.gif"):
            pass
    finally:
        signal.signal(number, previous)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_stop_inside_a_held_block_lands_after_it(sig):
    """What `stops_held` guards (mkstemp, a frame of matplotlib's C++ drawing) runs to its end;
    the stop is handled right after, by the handler that was there, which is put back."""
    import os
    import signal

    from vsmp_imu.io import stops_held

    number = getattr(signal, sig)
    previous = signal.signal(number, signal.default_int_handler)
    done = []
    try:
        with pytest.raises(KeyboardInterrupt), stops_held():
            os.kill(os.getpid(), number)
            for _ in range(1000):  # bytecodes at which an unheld signal's handler runs
                pass
            done.append("the block's end")
        assert done == ["the block's end"]
        assert signal.getsignal(number) is signal.default_int_handler
    finally:
        signal.signal(number, previous)


def test_stops_are_not_held_off_the_main_thread_or_over_a_handler_python_cannot_restore(monkeypatch):
    import signal
    import threading

    from vsmp_imu.io import stops_held

    seen = []

    def inside():
        with stops_held():
            seen.append(signal.getsignal(signal.SIGINT))

    worker = threading.Thread(target=inside)
    worker.start()
    worker.join()
    before = signal.getsignal(signal.SIGINT)
    assert seen == [before]  # off the main thread: nothing swapped (signal.signal would raise there)
    monkeypatch.setattr(signal, "getsignal", lambda sig: None if sig == signal.SIGTERM else before)
    with stops_held():
        assert signal.signal(signal.SIGINT, before) is before  # the handler was left in place


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


def _laughs(levels: int) -> str:
    """Each level lists the one before nine times: 9**levels strings from a few hundred bytes."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text,says", [
    (_laughs(10), "expand the document by more than 1,000,000 nodes"),
    ("p: &p [" + ", ".join(["x"] * 5000) + "]\nrefs: [" + ", ".join(["*p"] * 300) + "]\n",
     "expand the document by more than 1,000,000 nodes"),
    ("a: &a [1, *a]\n", "nest the document more than 100 deep"),  # an alias inside what it names
    ("".join(f"a{i}: &a{i} [[*a{i - 1}]]\n" if i else "a0: &a0 [x]\n" for i in range(60)),
     "nest the document more than 100 deep"),
], ids=["billion-laughs", "one-list-many-times", "self-reference", "alias-chain"])
def test_yaml_aliases_are_refused_before_they_expand(tmp_path, text, says):
    """A few hundred bytes of aliases once stood for 10**8 strings and took every byte of memory."""
    from vsmp_imu.errors import InputFileError

    path = tmp_path / "smp.yaml"
    path.write_text(text)
    with pytest.raises(InputFileError) as err:
        read_structured(path)
    assert says in err.value.render() and "smp.yaml" in err.value.render()


def test_the_alias_budget_counts_every_node_an_alias_adds():
    from vsmp_imu.io import AliasExpansionError, load_yaml

    text = "a: &a [1, 2, 3]\nb: [*a, *a]\n"  # each *a adds the list and its three items
    assert load_yaml(text, limit=8) == {"a": [1, 2, 3], "b": [[1, 2, 3], [1, 2, 3]]}
    with pytest.raises(AliasExpansionError):
        load_yaml(text, limit=7)


def test_the_largest_aliased_file_we_read_is_far_inside_the_budget():
    from pathlib import Path

    import yaml

    from vsmp_imu.io import MAX_ALIAS_NODES, YAML_LOADER, _expansion

    tables = Path(__file__).resolve().parents[1] / "results" / "tables.yaml"
    expanded, written = _expansion(yaml.compose(tables.read_text(), Loader=YAML_LOADER), 100)
    assert 0 < expanded - written < MAX_ALIAS_NODES / 100
    assert read_structured(tables)["tables"]


@pytest.mark.parametrize("name,text", [
    ("smp.json", '{"repetition_count": ' + "9" * 5000 + "}"),
    ("smp.yaml", "repetition_count: " + "9" * 5000 + "\n"),
])
def test_an_integer_too_long_for_python_is_invalid_input(tmp_path, name, text):
    from vsmp_imu.errors import InputFileError

    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputFileError) as err:
        read_structured(path)
    assert f"{name}: not valid {name[4:].upper()}: an integer has more than 4300 digits" in err.value.render()
