"""BVH export, rendering, and the `vsmp-imu motion` commands."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from vsmp_imu.errors import InputFileError
from vsmp_imu.motion import Motion
from vsmp_imu.motion.bvh import read_bvh, write_bvh
from vsmp_imu.motion.render import render_gif, render_keyframes

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "reliability"))
from reliability_support import TEMP_NAME, cli_command, wait_for  # noqa: E402


@pytest.fixture(scope="module")
def walk(backend, library) -> Motion:
    return backend.generate(library.get("walking").smp, seed=4, duration_s=2.0)


@pytest.mark.parametrize("scale", [1.0, 100.0])
def test_bvh_round_trip(tmp_path, walk, scale):
    path = write_bvh(walk, tmp_path / "walk.bvh", scale=scale)
    bvh = read_bvh(path)
    assert bvh.joint_names[0] == "pelvis" and len(bvh.joint_names) == 22
    assert bvh.frame_time_s == pytest.approx(1 / 30)
    assert bvh.frames.shape == (walk.n_frames, 6 + 3 * 21)
    order = [bvh.joint_names.index(n) for n in walk.joint_names]
    pos = bvh.positions()[:, order] / scale
    assert np.abs(pos - walk.positions).max() < 1e-3  # within a millimetre
    text = path.read_text()
    assert text.count("End Site") == 5  # head, wrists, feet
    assert "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" in text


def test_bvh_of_a_bad_file(tmp_path):
    bad = tmp_path / "bad.bvh"
    bad.write_text("HIERARCHY\nROOT a\n{\n OFFSET 0 0 x\n")
    with pytest.raises(InputFileError, match="not a readable BVH"):
        read_bvh(bad)


def test_render_gif_and_keyframes(tmp_path, walk):
    gif = render_gif(walk, tmp_path / "walk.gif", size_px=200)
    with Image.open(gif) as im:
        assert im.format == "GIF" and im.n_frames == len(range(0, walk.n_frames, 2))
    png = render_keyframes(walk, tmp_path / "walk.png", n=4, panel_px=120)
    with Image.open(png) as im:
        arr = np.asarray(im.convert("L"))
        assert im.size[0] > 3 * im.size[1]  # a strip
        assert (arr < 100).mean() > 0.002  # the skeleton is drawn
    assert {p.name for p in tmp_path.iterdir()} == {"walk.gif", "walk.png"}  # no temporary left


def test_a_motion_whose_meta_holds_megabytes_is_drawn_with_a_short_title(cli, tmp_path, walk):
    """A 1 MB `activity` in a motion file's meta went whole into every frame's title: `motion
    render` of 20 frames ran past 90 s and 700 MB, and SIGTERM then ended in a traceback."""
    from vsmp_imu.motion.render import TITLE_TEXT_CHARS, _title

    big = Motion(walk.positions[:20], walk.rotations[:20], walk.fps, walk.joint_names, walk.parents,
                 {**walk.meta, "activity": "x" * 1_000_000, "backend": "b" * 1000, "seed": 10**500})
    title = _title(big, 3)
    assert len(title) < 4 * TITLE_TEXT_CHARS and title.endswith("frame 3/19 (0.10 s)")
    assert title.startswith("x" * (TITLE_TEXT_CHARS - 1) + "\u2026 | ")
    assert _title(walk, 0).startswith("walking | procedural | seed 4 | ")  # short values as they were
    code, _, err = cli("motion", "render", big.save(tmp_path / "big.npz"), "-o", tmp_path / "big.gif")
    assert code == 0, err


@pytest.mark.parametrize("stop_at", [1, 4])  # the first drawing (no frame grabbed yet), a later one
def test_a_stopped_render_writes_no_gif_and_keeps_the_stop(tmp_path, walk, monkeypatch, stop_at):
    """matplotlib writes the frames grabbed so far as a GIF on the way out of a stop too (seconds
    of work for a file thrown away) and, with none grabbed yet, raised IndexError over it."""
    from vsmp_imu.motion import render

    saved, calls, draw = [], [], render._Scene.draw
    monkeypatch.setattr(Image.Image, "save", lambda self, *args, **kwargs: saved.append(args))

    def stopping(self, frame, title=None):
        calls.append(frame)
        if len(calls) == stop_at:
            raise KeyboardInterrupt
        draw(self, frame, title)

    monkeypatch.setattr(render._Scene, "draw", stopping)
    with pytest.raises(KeyboardInterrupt):
        render_gif(walk, tmp_path / "w.gif", size_px=100)
    assert saved == [] and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_render_stopped_by_sigterm_or_ctrl_c_ends_cleanly(tmp_path, walk, sig):
    """SIGTERM or Ctrl-C while `motion render` draws: exit 128 + signal with one line, no file
    under the output name and no temporary (stopped before a frame was grabbed, it ended in
    matplotlib's IndexError traceback, exit 1)."""
    repeat = 10  # 20 s: 200 frames to draw, seconds of work
    long = Motion(np.tile(walk.positions, (repeat, 1, 1)), np.tile(walk.rotations, (repeat, 1, 1)), walk.fps,
                  walk.joint_names, walk.parents, dict(walk.meta))
    path = long.save(tmp_path / "long.npz")
    proc = subprocess.Popen(cli_command("motion", "render", path, "-o", tmp_path / "long.gif"),
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:  # the render has started once its temporary GIF exists
        wait_for(lambda: proc.poll() is not None or any(TEMP_NAME.match(p.name) for p in tmp_path.iterdir()),
                 timeout_s=120, step_s=0.01)
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + sig, err
    assert "Traceback" not in err and " ".join(err.split()) == f"stopped by {sig.name}."
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.npz"]


def test_a_long_motion_is_shown_by_at_most_max_gif_frames_in_real_time(walk):
    from vsmp_imu.motion.render import MAX_GIF_FRAMES, gif_step

    repeat = 301  # 10 min at 30 fps
    long = Motion(np.tile(walk.positions, (repeat, 1, 1)), np.tile(walk.rotations, (repeat, 1, 1)), walk.fps,
                  walk.joint_names, walk.parents, dict(walk.meta))
    step, capped = gif_step(long)
    shown = len(range(0, long.n_frames, step))
    assert capped and MAX_GIF_FRAMES - 10 < shown <= MAX_GIF_FRAMES
    assert shown * step / long.fps == pytest.approx(long.duration_s, abs=step / long.fps)
    assert gif_step(walk) == (2, False)  # 30 fps: every other frame, 15 fps


def test_cli_render_says_when_the_gif_is_capped(cli, tmp_path, walk, monkeypatch):
    from vsmp_imu.motion import render

    monkeypatch.setattr(render, "MAX_GIF_FRAMES", 10)
    path = walk.save(tmp_path / "walk.npz")
    code, out, err = cli("motion", "render", path, "-o", tmp_path / "w.gif")
    assert code == 0, err
    with Image.open(tmp_path / "w.gif") as im:  # 61 frames, one in ceil(61 / 10) = 7 shown
        assert im.n_frames == 9 and im.info["duration"] == pytest.approx(1000 * 7 / walk.fps, abs=10)
    assert "shows 9 of the 61 frames (one in 7" in " ".join(out.split())


def test_cli_synth_info_render_bvh_resample(cli, tmp_path):
    out = tmp_path / "curl.npz"
    code, stdout, _ = cli("motion", "synth", "two_arm_curl", "--seed", "2", "-o", out)
    assert code == 0 and out.exists() and "two_arm_curl" in stdout
    m = Motion.load(out)
    assert m.meta["seed"] == 2 and m.meta["backend"] == "procedural"
    code, stdout, _ = cli("motion", "info", out)
    assert code == 0 and "two_arm_curl" in stdout and "procedural" in stdout
    code, _, _ = cli("motion", "render", out, "-o", tmp_path / "c.gif", "--keyframes", tmp_path / "c.png")
    assert code == 0 and (tmp_path / "c.gif").exists() and (tmp_path / "c.png").exists()
    code, _, _ = cli("motion", "bvh", out, "-o", tmp_path / "c.bvh")
    assert code == 0 and read_bvh(tmp_path / "c.bvh").frames.shape[0] == m.n_frames
    code, _, _ = cli("motion", "resample", out, "--fps", "60", "-o", tmp_path / "c60.npz")
    assert code == 0 and Motion.load(tmp_path / "c60.npz").fps == 60.0


def test_cli_render_writes_the_formats_its_file_names_say(cli, tmp_path, library):
    """The keyframe strip is written in the format its suffix names; the animation is a GIF and
    its name must say so; a suffix neither can be written in is refused before drawing."""
    from vsmp_imu.motion.procedural import ProceduralBackend

    path = ProceduralBackend(library).generate(library.get("walking").smp, 0, 2.0).save(tmp_path / "c.npz")
    code, _, err = cli("motion", "render", path, "-o", tmp_path / "c.gif", "--keyframes", tmp_path / "k.svg",
                       "--n", "2")
    assert code == 0, err
    assert (tmp_path / "k.svg").read_text().lstrip().startswith("<?xml") and "<svg" in (tmp_path / "k.svg").read_text()
    assert (tmp_path / "c.gif").read_bytes()[:4] == b"GIF8"
    code, _, err = cli("motion", "render", path, "-o", tmp_path / "d.gif", "--keyframes", tmp_path / "k.txt")
    assert code == 2 and "field '--keyframes'" in err and "'.txt' is not an image format" in err
    code, _, err = cli("motion", "render", path, "-o", tmp_path / "d.png")
    assert code == 2 and "field '--output'" in err and "ending in .gif" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.gif", "c.npz", "k.svg"]


def test_cli_synth_from_file_prompt_and_duration(cli, tmp_path, library):
    from vsmp_imu.smp import save_smp

    smp_file = save_smp(library.get("jumping_jacks").smp, tmp_path / "jj.json")
    code, _, _ = cli("motion", "synth", smp_file, "--seed", "1", "--duration-s", "12", "-o", tmp_path / "a.npz")
    assert code == 0 and Motion.load(tmp_path / "a.npz").duration_s == pytest.approx(12.0)
    code, _, _ = cli("motion", "synth", "--prompt", "a person claps their hands quickly",
                     "--seed", "1", "-o", tmp_path / "b.npz")
    assert code == 0 and Motion.load(tmp_path / "b.npz").meta["activity"] == "two_hand_front_clap"


def test_cli_synth_never_swaps_a_look_alike_activity(cli, tmp_path, library):
    from vsmp_imu.smp import save_smp

    curl = library.get("bicep_curls").smp
    # an exact alias keeps working
    alias = save_smp(curl.model_copy(update={"activity_label": "Dumbbell-Curls"}), tmp_path / "alias.json")
    code, _, _ = cli("motion", "synth", alias, "--seed", "1", "-o", tmp_path / "a.npz")
    assert code == 0 and Motion.load(tmp_path / "a.npz").meta["activity"] == "bicep_curls"
    # a label that only resembles library activities is never animated as one of them: by default
    # the SMP is compiled into its own motion (it used to become baseball_swing)
    hammer_smp = curl.model_copy(update={"activity_label": "hammer curl with a kettlebell"})
    hammer = save_smp(hammer_smp, tmp_path / "hammer.json")
    code, _, _ = cli("motion", "synth", hammer, "--seed", "1", "-o", tmp_path / "h.npz")
    meta = Motion.load(tmp_path / "h.npz").meta
    assert code == 0 and meta["motion_source"] == "compiled" and meta["activity"] != "baseball_swing"
    # with library recipes only, it stops naming the candidates
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.library import ActivityMatchError

    with pytest.raises(ActivityMatchError) as err:
        ProceduralBackend(library=library, compile_mode="recipe").generate(hammer_smp, seed=1)
    names = [name for name, _ in err.value.candidates]
    assert "bicep_curls" in names and "baseball_swing" in names
    assert str(err.value.in_file(hammer)).startswith(f"{hammer}:")


@pytest.mark.parametrize(("args", "words"), [
    (("motion", "synth", "moonwalk_backwards", "--seed", "1", "-o", "x.npz"), "neither an SMP file"),
    (("motion", "synth", "walking", "--seed", "1", "--backend", "mocap", "-o", "x.npz"),
     "field '--backend': unknown motion backend 'mocap'. Allowed: procedural, compiled, hymotion."),
    (("motion", "synth", "walking", "--seed", "1", "--backend", "hymotion", "-o", "x.npz"), "HY-Motion"),
    (("motion", "synth", "--seed", "1", "-o", "x.npz"), "give an SMP"),
    (("motion", "info", "missing.npz"), "file not found"),
])
def test_cli_user_mistakes_exit_2(cli, tmp_path, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    code, _, err = cli(*args)
    assert code == 2 and words in err


@pytest.mark.parametrize(("args", "says"), [
    (("motion", "synth", "walking", "--seed", "0", "-o", "w.parquet"),
     "w.parquet: field '--output': a motion is written as .npz, not under '.parquet'. Allowed: a file name ending in .npz."),
    (("motion", "synth", "walking", "--seed", "0", "-o", "w"), "w: field '--output': a motion is written as .npz, not "
     "under a name without one."),
    (("motion", "resample", "w.npz", "--fps", "60", "-o", "w.csv"), "w.csv: field '--output': a motion is written as .npz"),
    (("motion", "bvh", "w.npz", "-o", "w.txt"),  # a BVH text went into 'w.txt'
     "w.txt: field '--output': a BVH motion is written as .bvh, not under '.txt'. Allowed: a file name ending in .bvh."),
    (("imu", "simulate", "w.npz", "-o", "w.parquet"),
     "w.parquet: field '--output': an IMU recording is written as .csv, not under '.parquet'. Allowed: a file name "
     "ending in .csv."),
    (("motion", "render", "w.npz", "-o", "w.png"),
     "w.png: field '--output': the animation is written as .gif, not under '.png'. Allowed: a file name ending in .gif."),
    (("video", "pose", "clip.mp4", "-o", "w.json"), "w.json: field '--output': a motion is written as .npz, not under "
     "'.json'"),
])
def test_an_output_named_for_another_format_is_refused(cli, tmp_path, walk, monkeypatch, args, says):
    """A motion went into 'w.csv' as a zip and an IMU CSV into 'w.parquet' as text, each under a
    name that said another format."""
    monkeypatch.chdir(tmp_path)
    walk.save(tmp_path / "w.npz")
    code, _, err = cli(*args)
    assert code == 2 and says in " ".join(err.split()), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.npz"]


@pytest.mark.parametrize(("args", "says"), [
    (("render", "--keyframes", "k.png", "--n", "0"), "field '--n': 0 keyframes cannot be drawn. Allowed: 1..60."),
    (("render", "--n", "61"), "field '--n': 61 keyframes cannot be drawn. Allowed: 1..60."),
    (("render", "--view", "400"), "field '--view': 400 is not a camera azimuth. Allowed: -360..360 degrees."),
    (("render", "--view", "nan"), "field '--view': nan is not a camera azimuth."),
    (("bvh", "--scale", "0"), "field '--scale': 0 is not a usable unit scale. Allowed: 0.01..1000"),
])
def test_cli_render_and_bvh_range_errors_name_the_option_typed(cli, tmp_path, walk, monkeypatch, args, says):
    """The checks' own names for the settings (n, yaw_deg, scale) become the options, before
    anything is drawn or written."""
    monkeypatch.chdir(tmp_path)
    walk.save(tmp_path / "w.npz")
    command, *rest = args
    out = "w.gif" if command == "render" else "w.bvh"
    code, _, err = cli("motion", command, "w.npz", "-o", out, *rest)
    assert code == 2 and says in err, err
    assert "field 'n'" not in err and "yaw_deg" not in err and "field 'scale'" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.npz"]
