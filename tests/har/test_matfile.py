"""MATLAB 5 files are walked before scipy's reader sees them (har/datasets/matfile.py).

scipy's C reader crashes the process (a segmentation fault) on a data tag of an unknown type;
tests/reliability/test_fuzz.py found it through the UTD-MHAD loader. Each damaged file here is
one the walk refuses and the loader skips, naming why; files scipy writes pass and read alike.
"""

import io
import re
import shutil
import struct
import zlib

import numpy as np
import pytest
import scipy.sparse
from scipy.io import loadmat, savemat

from vsmp_imu.har.datasets import load_dataset, matfile
from vsmp_imu.har.datasets.matfile import MatFileError, check_mat5, load_mat

DATA_TAG = 184  # a UTD-MHAD file: header 128, matrix tag, flags, dimensions, name 'd_iner'; then its numbers


@pytest.fixture
def recording(fixtures_dir) -> bytes:
    return (fixtures_dir / "utd_mhad" / "Inertial" / "a1_s1_t1_inertial.mat").read_bytes()


def with_word(data: bytes, pos: int, value: int) -> bytes:
    return data[:pos] + struct.pack("<I", value) + data[pos + 4:]


def test_the_recording_reads_as_scipy_reads_it(recording, tmp_path):
    path = tmp_path / "a1_s1_t1_inertial.mat"
    path.write_bytes(recording)
    assert np.array_equal(load_mat(path)["d_iner"], loadmat(path)["d_iner"])
    assert struct.unpack("<I", recording[DATA_TAG:DATA_TAG + 4])[0] == 9  # miDOUBLE: the offset is right


@pytest.mark.parametrize("code", [0, 8, 10, 11, 14, 15, 19, 20, 7680])
def test_a_data_tag_of_a_type_the_reader_cannot_look_up_is_refused(recording, code):
    with pytest.raises(MatFileError, match=f"unknown type {code} at byte {DATA_TAG}"):
        check_mat5(with_word(recording, DATA_TAG, code))


@pytest.mark.parametrize(("damage", "says"), [
    (lambda d: d[:100], "shorter than a MATLAB 5 header"),
    (lambda d: b"\0\0\0\0" + d[4:], "version 4 file"),
    (lambda d: d[:126] + b"XX" + d[128:], "no byte-order mark"),
    (lambda d: d[:124] + b"\x00\x02" + d[126:], "version 0x0200"),
    (lambda d: d[:333], "past its end"),
    (lambda d: with_word(d, 128, 9), "top-level element of type 9"),
    (lambda d: with_word(d, 136, 5), "does not start with its array flags"),
    (lambda d: with_word(d, 156, 0x7FFFFFF0), "past its end"),
    (lambda d: d[:160] + struct.pack("<ii", -5, 6) + d[168:], "are not an array's"),
    (lambda d: with_word(d, 168, 0x00090001), "claims 9 bytes (at most 4)"),
])
def test_a_damaged_structure_is_refused_naming_what(recording, damage, says):
    with pytest.raises(MatFileError, match=re.escape(says)):
        check_mat5(damage(recording))


VARIABLES = {"d": np.random.default_rng(0).random((50, 6)), "z": np.array([1 + 2j]), "text": "hello",
             "cell": np.array([np.arange(3), "x"], dtype=object), "st": {"a": np.arange(4), "b": {"c": "y"}},
             "sp": scipy.sparse.random(5, 5, density=0.3, format="csc", random_state=0),
             "i": np.arange(7, dtype=np.int16), "empty": np.zeros((0, 3))}


@pytest.mark.parametrize("compressed", [False, True])
def test_what_scipy_writes_passes_and_reads_alike(tmp_path, compressed):
    path = tmp_path / "all.mat"
    savemat(path, VARIABLES, do_compression=compressed)
    check_mat5(path.read_bytes())
    ours, theirs = load_mat(path), loadmat(path)
    assert set(ours) == set(theirs) and np.array_equal(ours["d"], theirs["d"])


def test_a_compressed_element_is_inflated_within_a_cap(tmp_path, monkeypatch):
    buffer = io.BytesIO()
    savemat(buffer, {"d": np.zeros((400, 6))}, do_compression=True)
    data = buffer.getvalue()
    check_mat5(data)
    monkeypatch.setattr(matfile, "MAX_INFLATED_BYTES", 1000)  # 400 x 6 doubles inflate to 19 kB
    with pytest.raises(MatFileError, match="inflates to more than"):
        check_mat5(data)
    broken = data[:136] + bytes(8) + data[144:]
    with pytest.raises(MatFileError, match="does not inflate"):
        check_mat5(broken)
    packed = zlib.compress(struct.pack("<II", 9, 8) + bytes(8))
    with pytest.raises(MatFileError, match="holds type 9"):
        check_mat5(data[:128] + struct.pack("<II", 15, len(packed)) + packed)


def test_cells_nested_too_deep_are_refused():
    value = np.arange(2)
    for _ in range(matfile.MAX_DEPTH + 2):
        value = np.array([value, "x"], dtype=object)
    buffer = io.BytesIO()
    savemat(buffer, {"deep": value})
    with pytest.raises(MatFileError, match="nested more than"):
        check_mat5(buffer.getvalue())


def test_the_loader_skips_a_file_the_walk_refuses(fixtures_dir, tmp_path, recording):
    folder = tmp_path / "utd"
    shutil.copytree(fixtures_dir / "utd_mhad", folder)
    (folder / "Inertial" / "a1_s1_t1_inertial.mat").write_bytes(with_word(recording, DATA_TAG, 0))
    ds = load_dataset("utd-mhad", folder)
    assert "a1_s1_t1" not in {r.recording_id for r in ds.recordings()}
    assert ds.skipped == [f"a1_s1_t1_inertial.mat: unreadable (an element of unknown type 0 at byte {DATA_TAG})"]
