"""What `Motion.load` refuses in a motion file, and how the commands that read motions report it.

Each damaged file is a short synthesized motion with one field broken; every refusal is exit 2
with the file and the field named, never a traceback, a huge allocation or a NaN written out.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.motion import Motion
from vsmp_imu.motion.bvh import bvh_text, read_bvh


@pytest.fixture(scope="module")
def walk(backend, library) -> Motion:
    return backend.generate(library.get("walking").smp, seed=0, duration_s=1.0)


def _save(tmp_path, motion: Motion, name: str = "m.npz", **damage):
    """`motion` as an .npz with some keys replaced (None: the key left out)."""
    arrays = {"positions": motion.positions, "rotations": motion.rotations, "fps": np.float64(motion.fps),
              "joint_names": np.array(motion.joint_names), "parents": np.array(motion.parents),
              "meta": np.array(json.dumps(motion.meta))}
    arrays.update(damage)
    path = tmp_path / name
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None})
    return path


def _set(array: np.ndarray, index, value) -> np.ndarray:
    out = np.array(array, copy=True)
    out[index] = value
    return out


DAMAGE = {  # name: (the damaged keys from the motion, the field named, words of the message)
    "meta_list": (lambda m: {"meta": np.array("[1, 2]")}, "meta", "JSON object"),
    "meta_str": (lambda m: {"meta": np.array('"hello"')}, "meta", "JSON object"),
    "meta_bad": (lambda m: {"meta": np.array("{not json")}, "meta", "not JSON"),
    "fps_tiny": (lambda m: {"fps": np.float64(1e-6)}, "fps", "1..1000"),
    "fps_huge": (lambda m: {"fps": np.float64(1e9)}, "fps", "1..1000"),
    "fps_pair": (lambda m: {"fps": np.array([30.0, 31.0])}, "fps", "one number"),
    "too_long": (lambda m: {"fps": np.float64(1.0), "positions": np.resize(m.positions, (700, 22, 3)),
                            "rotations": np.resize(m.rotations, (700, 22, 4))}, "positions", "at most 600 s"),
    "nan_pos": (lambda m: {"positions": _set(m.positions, (5, 3, 1), np.nan)}, "positions",
                "nan at frame 5, joint 3"),
    "huge_pos": (lambda m: {"positions": m.positions * 1e300}, "positions", "within ±10000 m"),
    "zero_quat": (lambda m: {"rotations": _set(m.rotations, (5, 3), 0.0)}, "rotations",
                  "norm of 0 at frame 5, joint 3"),
    "nan_quat": (lambda m: {"rotations": _set(m.rotations, (5, 3, 0), np.nan)}, "rotations",
                 "norm of nan at frame 5, joint 3"),
    "parent_oob": (lambda m: {"parents": _set(m.parents, 3, 99)}, "parents", "parent 99 of joint 3 is not a joint"),
    "parent_neg": (lambda m: {"parents": _set(m.parents, 3, -5)}, "parents", "parent -5 of joint 3"),
    "parent_self": (lambda m: {"parents": _set(m.parents, 3, 3)}, "parents", "do not descend from the root"),
    "parent_cycle": (lambda m: {"parents": _set(_set(m.parents, 1, 2), 2, 1)}, "parents", "cycle"),
    "root_self": (lambda m: {"parents": _set(m.parents, 0, 0)}, "parents", "has 0"),
    "float_parents": (lambda m: {"parents": np.array(m.parents, dtype=float)}, "parents", "integers"),
    "meta_deep": (lambda m: {"meta": np.array('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")}, "meta",
                  "nests lists or objects too deeply"),
    "names_twice": (lambda m: {"joint_names": _set(m.joint_names, 1, "pelvis")}, "joint_names", "more than once"),
}


@pytest.mark.parametrize("case", sorted(DAMAGE))
def test_load_refuses_a_damaged_motion_naming_file_and_field(tmp_path, walk, case):
    damage, field, words = DAMAGE[case]
    path = _save(tmp_path, walk, f"{case}.npz", **damage(walk))
    with pytest.raises(ValidationError) as err:
        Motion.load(path)
    assert err.value.file == str(path) and err.value.field == field
    assert words in str(err.value)


def test_a_text_file_is_not_a_motion_and_nothing_suggests_unpickling(tmp_path):
    text = tmp_path / "m.npz"
    text.write_text("hello\n")
    with pytest.raises(InputFileError) as err:
        Motion.load(text)
    message = str(err.value)
    assert message.startswith(f"{text}:") and "not a motion file (.npz)" in message
    assert "pickle" not in message


def test_motions_the_project_writes_pass_the_file_checks(tmp_path, walk):
    from test_motion_hymotion import _hy_output

    from vsmp_imu.extract.calibrate import motion_track
    from vsmp_imu.extract.retarget import track_to_motion
    from vsmp_imu.motion.hymotion import motion_from_hymotion

    hy = motion_from_hymotion(_hy_output()[0])
    video = track_to_motion(motion_track(walk))
    for name, motion in {"procedural": walk, "hymotion": hy, "video": video}.items():
        motion.check_values()
        assert Motion.load(motion.save(tmp_path / f"{name}.npz")).n_frames == motion.n_frames
    # an integer fps, no meta and an extra key are still read
    path = _save(tmp_path, walk, fps=np.int64(30), meta=None, extra=np.zeros(3))
    assert Motion.load(path).meta == {}


def test_a_long_fast_run_is_within_the_position_bound(tmp_path, backend, library):
    """Ten minutes of running travel about a kilometre: far below the bound on coordinates."""
    run = backend.generate(library.get("running").smp, seed=0, duration_s=60.0)
    travel = np.abs(run.positions).max() * 10
    assert 500 < travel < 1e4 / 4
    run.check_values()


def test_bvh_of_a_motion_with_another_skeleton_keeps_every_joint(cli, tmp_path, walk):
    names = np.array([f"j{i}" for i in range(walk.n_joints)])
    path = _save(tmp_path, walk, joint_names=names)
    code, stdout, _ = cli("motion", "info", path)
    assert code == 0 and "n/a" in stdout
    code, _, err = cli("motion", "render", path, "-o", tmp_path / "m.gif")
    assert code == 2 and err.startswith(f"{path}: field 'joint_names'") and "pelvis" in err
    code, _, _ = cli("motion", "bvh", path, "-o", tmp_path / "m.bvh")
    assert code == 0 and len(read_bvh(tmp_path / "m.bvh").joint_names) == walk.n_joints


def test_bvh_of_a_skeleton_chained_deeper_than_python_recursion(cli, tmp_path):
    """A 3000-joint chain once stopped `motion bvh` with a RecursionError traceback."""
    n = 3000
    positions = np.zeros((2, n, 3))
    positions[:, :, 1] = np.arange(n) * 1e-3
    rotations = np.zeros((2, n, 4))
    rotations[..., 3] = 1.0
    chain = Motion(positions, rotations, 30.0, tuple(f"j{i}" for i in range(n)), (-1, *range(n - 1)))
    out = tmp_path / "chain.bvh"
    code, _, err = cli("motion", "bvh", chain.save(tmp_path / "chain.npz"), "-o", out)
    assert code == 0, err
    back = read_bvh(out)
    assert back.parents == [-1, *range(n - 1)] and back.frames.shape == (2, 6 + 3 * (n - 1))


@pytest.mark.parametrize(("name", "says"), [("MOTION", "is a BVH keyword"), ("a{b}", "has '{'"),
                                            ("hip}", "has '}'"), ("x\x1b[31m", "has '\\x1b'")])
def test_bvh_refuses_a_joint_name_that_would_break_its_structure(cli, tmp_path, walk, name, says):
    """Such a name was written into the hierarchy as it was: a BVH that reads back wrong or not at all."""
    path = _save(tmp_path, walk, joint_names=_set(walk.joint_names, 5, name))
    out = tmp_path / "m.bvh"
    code, _, err = cli("motion", "bvh", path, "-o", out)
    assert code == 2 and err.startswith(f"{path}: field 'joint_names': joint 5's name"), err
    assert says in err and "not a BVH keyword" in err and not out.exists()


@pytest.mark.parametrize("scale", ["nan", "inf", "0", "-1", "1e308"])
def test_bvh_scale_must_be_a_usable_unit(cli, tmp_path, walk, scale):
    out = tmp_path / "m.bvh"
    code, _, err = cli("motion", "bvh", walk.save(tmp_path / "m.npz"), "-o", out, f"--scale={scale}")
    assert code == 2 and "field '--scale'" in err and "0.01..1000" in err and not out.exists()


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning", "ignore:invalid value:RuntimeWarning")
def test_bvh_text_refuses_values_that_overflow(walk):
    far = Motion(walk.positions * 1e306, walk.rotations, walk.fps, meta=walk.meta)
    with pytest.raises(ValidationError, match="not be finite"):
        bvh_text(far, scale=1000.0)


def test_commands_name_the_damaged_file(cli, tmp_path, walk):
    nan = _save(tmp_path, walk, "nan.npz", positions=_set(walk.positions, (5, 3, 1), np.nan))
    for args in (("motion", "bvh", nan, "-o", tmp_path / "x.bvh"),
                 ("motion", "resample", nan, "--fps", "60", "-o", tmp_path / "x.npz"),
                 ("imu", "simulate", nan, "-o", tmp_path / "x.csv"),
                 ("motion", "info", nan)):
        code, _, err = cli(*args)
        assert code == 2 and err.startswith(f"{nan}: field 'positions'")
    assert not any(tmp_path.glob("x.*"))


def test_resample_never_writes_nan_and_names_fps_as_the_option(cli, tmp_path, walk):
    with pytest.raises(ValidationError, match="non-finite"):
        Motion(_set(walk.positions, (5, 3, 1), np.nan), walk.rotations, walk.fps).resample(60.0)
    two = _save(tmp_path, walk, "two.npz", positions=walk.positions[:2], rotations=walk.rotations[:2])
    code, _, err = cli("motion", "resample", two, "--fps", "10", "-o", tmp_path / "x.npz")
    assert code == 2 and err.startswith(f"{two}: field '--fps'") and "at least 30 fps" in err
    joints = 20_000  # 1001 frames of them at 1000 fps would be 1.04 GiB
    wide = Motion(np.zeros((2, joints, 3)), np.tile([0.0, 0.0, 0.0, 1.0], (2, joints, 1)), 1.0,
                  [f"j{i}" for i in range(joints)], [-1] + [0] * (joints - 1))
    with pytest.raises(ValidationError, match="at most 1024 MiB"):
        wide.resample(1000.0)


def test_imu_simulate_names_trim_s_by_its_option(cli, tmp_path, walk):
    three = _save(tmp_path, walk, "three.npz", positions=walk.positions[:3], rotations=walk.rotations[:3])
    code, _, err = cli("imu", "simulate", three, "-o", tmp_path / "x.csv")
    assert code == 2 and err.startswith(f"{three}: field '--trim-s'")
