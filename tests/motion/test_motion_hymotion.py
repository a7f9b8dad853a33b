"""HY-Motion backend: conversion of its real output structure, the runtime call, clear errors.

HY-Motion itself (weights, GPU) is not available here; its output is rebuilt
in the runtime's exact structure (`T2MRuntime.generate_motion(...,
output_format="dict")` returns `(html, fbx_files, output)`; `output` holds
batch-first float32 torch tensors `rot6d` (B, L, 22, 6), `transl` (B, L, 3),
`keypoints3d` (B, L, 52, 3) without the translation, `root_rotations_mat`,
`latent_denorm`, and `text`), from known rotations through our own FK.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import DependencyError, ValidationError
from vsmp_imu.motion import hymotion
from vsmp_imu.motion.hymotion import (
    HYMotionBackend,
    matrix_to_rot6d,
    motion_from_hymotion,
    rot6d_to_matrix,
)
from vsmp_imu.motion.quat import forward_kinematics
from vsmp_imu.motion.skeleton import smpl22_skeleton

N, B = 45, 2


def _hy_output(seed: int = 0):
    """(output dict in HY-Motion's structure, expected positions (B, L, 22, 3), expected global quats)."""
    rng = np.random.default_rng(seed)
    sk = smpl22_skeleton(1.75)
    t = np.arange(N) / 30.0
    rot6d, transl, kp, exp_pos, exp_rot = [], [], [], [], []
    for b in range(B):
        rv = 0.4 * np.sin(2 * np.pi * (0.5 + b) * t[:, None, None] + rng.uniform(0, 6, (1, 22, 3)))
        rv[:, 0] *= 0.3
        local = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat().reshape(N, 22, 4)
        root_rest = np.array([0.0, -0.2, 0.03])  # the skinning model's pelvis rest position
        posed, glob = forward_kinematics(sk.offsets, sk.parents, local, np.tile(root_rest, (N, 1)))
        tr = np.stack([0.3 * t, 0.95 + 0.02 * np.sin(4 * t), 0.5 * t], axis=1)
        world = posed + tr[:, None]
        min_y = world[..., 1].min() - 0.02  # HY grounds by its lowest mesh vertex (below the joints)
        fingers = np.repeat(posed[:, 20:22], 15, axis=1)  # 30 finger joints near the wrists
        k = np.concatenate([posed, fingers], axis=1)
        k[..., 1] -= min_y
        tr_out = tr.copy()
        tr_out[:, 1] -= min_y
        mats = Rotation.from_quat(local.reshape(-1, 4)).as_matrix().reshape(N, 22, 3, 3)
        rot6d.append(matrix_to_rot6d(mats))
        transl.append(tr_out)
        kp.append(k)
        exp_pos.append(world)
        exp_rot.append(glob)
    f32 = lambda a: torch.tensor(np.array(a), dtype=torch.float32)  # noqa: E731
    rot6d_t = f32(rot6d)
    output = {
        "latent_denorm": torch.zeros(B, N, 201),
        "keypoints3d": f32(kp),
        "rot6d": rot6d_t,
        "transl": f32(transl),
        "root_rotations_mat": torch.tensor(rot6d_to_matrix(rot6d_t[:, :, 0].numpy()), dtype=torch.float32),
        "text": "A person walks.",
    }
    return output, np.array(exp_pos), np.array(exp_rot)


def test_rot6d_round_trip_uses_the_first_two_columns():
    mats = Rotation.random(10, random_state=0).as_matrix()
    six = matrix_to_rot6d(mats)
    assert np.allclose(six[:, [0, 2, 4]], mats[:, :, 0]) and np.allclose(six[:, [1, 3, 5]], mats[:, :, 1])
    assert np.allclose(rot6d_to_matrix(six), mats)
    # not orthonormal input is orthonormalized (Gram-Schmidt)
    assert np.allclose(np.linalg.det(rot6d_to_matrix(six * 1.7 + 0.01)), 1.0)


@pytest.mark.parametrize("index", [0, 1])
def test_conversion_recovers_known_motion(index):
    output, exp_pos, exp_rot = _hy_output()
    m = motion_from_hymotion(output, index=index, meta={"seed": 5})
    assert m.fps == 30.0 and m.n_joints == 22 and m.n_frames == N
    pos = m.positions
    # horizontal positions exact (float32 precision); vertical up to the re-grounding shift
    assert np.abs(pos[..., [0, 2]] - exp_pos[index][..., [0, 2]]).max() < 1e-5
    dy = pos[..., 1] - exp_pos[index][..., 1]
    assert np.ptp(dy) < 1e-5
    feet = [m.joint_index(j) for j in ("left_foot", "right_foot", "left_ankle", "right_ankle")]
    assert 0.0 < pos[:, feet, 1].min() < 0.08
    same = np.abs((m.rotations * exp_rot[index]).sum(axis=-1))
    assert np.allclose(same, 1.0, atol=1e-5)
    assert m.meta["backend"] == "hymotion" and m.meta["seed"] == 5
    raw_y = (output["keypoints3d"][index, :, :22, 1] + output["transl"][index, :, None, 1]).numpy()
    assert np.allclose(pos[..., 1] - raw_y, m.meta["floor_shift_m"], atol=1e-5)


@pytest.mark.parametrize(("mutate", "words"), [
    (lambda o: o.pop("rot6d"), "lacks rot6d"),
    (lambda o: o.__setitem__("transl", o["transl"][:, :10]), "frame counts differ"),
    (lambda o: o.__setitem__("rot6d", o["rot6d"][:, :, :5]), "at least 22"),
    (lambda o: o.__setitem__("keypoints3d", o["keypoints3d"][0]), "must have 4 axes"),
])
def test_malformed_output_is_a_clear_error(mutate, words):
    output, _, _ = _hy_output()
    mutate(output)
    with pytest.raises(ValidationError, match=words):
        motion_from_hymotion(output)
    with pytest.raises(ValidationError, match="out of range"):
        motion_from_hymotion(_hy_output()[0], index=5)


class RecordingRuntime:
    """Stands in for T2MRuntime: same `generate_motion` signature and return value."""

    def __init__(self) -> None:
        self.calls: list[dict] = []

    def generate_motion(self, text, seeds_csv, duration, cfg_scale, output_format="fbx",
                        output_dir=None, output_filename=None, original_text=None,
                        use_special_game_feat=False):
        self.calls.append(dict(text=text, seeds_csv=seeds_csv, duration=duration, cfg_scale=cfg_scale,
                               output_format=output_format, output_dir=output_dir))
        output, _, _ = _hy_output(int(seeds_csv))
        output = {k: (v[:1] if hasattr(v, "shape") else v) for k, v in output.items()}
        return "<html></html>", [], output


def test_backend_verbalizes_and_calls_the_runtime(library):
    runtime = RecordingRuntime()
    backend = HYMotionBackend(runtime=runtime, library=library, cfg_scale=4.0)
    smp = library.get("two_arm_curl").smp
    m = backend.generate(smp, seed=3)
    call = runtime.calls[-1]
    assert call["output_format"] == "dict" and call["seeds_csv"] == "3" and call["cfg_scale"] == 4.0
    assert call["text"].startswith("A person performs two arm curl")
    assert 0.5 <= call["duration"] <= 12.0
    assert m.meta["prompt"] == call["text"] and m.meta["smp_id"] == smp.smp_id
    assert m.meta["activity"] == "two_arm_curl" and m.meta["seed"] == 3
    backend.generate("A person jumps.", seed=1, duration_s=30.0)
    assert runtime.calls[-1]["duration"] == 12.0 and runtime.calls[-1]["text"] == "A person jumps."


def test_missing_package_gpu_or_weights_are_dependency_errors(monkeypatch, tmp_path):
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(hymotion.importlib.util, "find_spec",
                        lambda name, *a: None if name == "hymotion" else real_find_spec(name, *a))
    with pytest.raises(DependencyError, match="not installed") as info:
        hymotion.check_available(tmp_path)
    assert "--backend procedural" in info.value.render()
    monkeypatch.setattr(hymotion.importlib.util, "find_spec",
                        lambda name, *a: object() if name == "hymotion" else real_find_spec(name, *a))
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    with pytest.raises(DependencyError, match="CUDA GPU"):
        hymotion.check_available(tmp_path)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    with pytest.raises(DependencyError, match="weights not found") as info:
        hymotion.check_available(tmp_path)
    assert "huggingface-cli download tencent/HY-Motion-1.0" in info.value.render()
    (tmp_path / "config.yml").write_text("x")
    (tmp_path / "latest.ckpt").write_text("x")
    assert hymotion.check_available(tmp_path) == tmp_path


def test_backend_without_hymotion_fails_cleanly(library):
    if importlib.util.find_spec("hymotion") is not None:
        pytest.skip("HY-Motion is installed here")
    with pytest.raises(DependencyError, match="not installed"):
        HYMotionBackend(library=library).generate(library.get("walking").smp, seed=0)
