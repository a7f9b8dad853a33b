"""Draw a motion: an animated GIF and a keyframe strip (PNG), with matplotlib.

The skeleton is drawn in a fixed oblique projection (camera in front of the
body, to its right and slightly above), with equal scale on both screen
axes and a floor grid. Left limbs are blue, right limbs red, the trunk dark.
"""

from __future__ import annotations

import contextlib
import math
from pathlib import Path

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.io import atomic_path, check_image_path, stops_held, write_figure
from vsmp_imu.motion.motion import Motion

CAMERA_YAW_DEG = -45.0  # camera azimuth from the front (+Z) toward the body's left (+X)
CAMERA_ELEVATION_DEG = 15.0
LEFT_COLOR, RIGHT_COLOR, CENTER_COLOR = "#1f5fbf", "#c8342b", "#333333"
GIF_MAX_FPS = 15.0
# 20 s at 15 fps; a longer motion is shown by fewer frames per second, still in real time
# (matplotlib draws each frame, and Pillow holds them all in memory until the GIF is written)
MAX_GIF_FRAMES = 300
MAX_KEYFRAMES = 60  # a strip of 60 panels is already 13 200 px wide


def check_render_options(n: int | None = None, yaw_deg: float | None = None) -> None:
    """Range checks of the keyframe count and the camera azimuth, made before anything is drawn."""
    if n is not None and not 1 <= n <= MAX_KEYFRAMES:
        raise ValidationError(f"{n} keyframes cannot be drawn", field="n", allowed=f"1..{MAX_KEYFRAMES}")
    if yaw_deg is not None and not -360.0 <= yaw_deg <= 360.0:  # NaN fails too
        raise ValidationError(f"{yaw_deg:g} is not a camera azimuth", field="yaw_deg",
                              allowed="-360..360 degrees")


def _camera(yaw_deg: float | None = None, elev_deg: float | None = None) -> np.ndarray:
    """(2, 3) matrix from world (x, y, z) to screen (u right, v up)."""
    yaw_deg = CAMERA_YAW_DEG if yaw_deg is None else yaw_deg
    elev_deg = CAMERA_ELEVATION_DEG if elev_deg is None else elev_deg
    yaw, elev = np.radians(yaw_deg), np.radians(elev_deg)
    # `view` points from the body to the camera; the body's front (+Z) faces the camera at yaw 0
    view = np.array([np.sin(yaw) * np.cos(elev), np.sin(elev), np.cos(yaw) * np.cos(elev)])
    right = np.cross(np.array([0.0, 1.0, 0.0]), view)
    right /= np.linalg.norm(right)
    up = np.cross(view, right)
    return np.stack([right, up])


def project(points: np.ndarray, camera: np.ndarray | None = None) -> np.ndarray:
    """Screen coordinates (..., 2) of world points (..., 3)."""
    cam = _camera() if camera is None else camera
    return points @ cam.T


def _bone_colors(motion: Motion) -> list[str]:
    colors = []
    for name in motion.joint_names:
        colors.append(LEFT_COLOR if name.startswith("left") else RIGHT_COLOR if name.startswith("right")
                      else CENTER_COLOR)
    return colors


TITLE_TEXT_CHARS = 60  # of each provenance value in a title: a file's meta may hold megabytes


def _cut(value: object) -> str:
    """A provenance value as title text, cut to TITLE_TEXT_CHARS (matplotlib lays out every
    character of a title on every frame: a 1 MB label once held `motion render` for minutes)."""
    text = str(value)
    return text if len(text) <= TITLE_TEXT_CHARS else text[:TITLE_TEXT_CHARS - 1] + "\u2026"


def _title(motion: Motion, frame: int) -> str:
    activity = motion.meta.get("activity") or motion.meta.get("activity_label") or "motion"
    seed = motion.meta.get("seed")
    backend = motion.meta.get("backend")
    parts = [_cut(activity)]
    if backend:
        parts.append(_cut(backend))
    if seed is not None:
        parts.append(f"seed {_cut(seed)}")
    parts.append(f"frame {frame}/{motion.n_frames - 1} ({frame / motion.fps:.2f} s)")
    return " | ".join(parts)


def _floor_segments(low: np.ndarray, high: np.ndarray, step: float) -> np.ndarray:
    """Grid lines on y = 0 covering the (x, z) box [low, high]: (L, 2, 3)."""
    x0, z0 = np.floor(low / step) * step
    x1, z1 = np.ceil(high / step) * step
    lines = [[[x, 0.0, z0], [x, 0.0, z1]] for x in np.arange(x0, x1 + 1e-9, step)]
    lines += [[[x0, 0.0, z], [x1, 0.0, z]] for z in np.arange(z0, z1 + 1e-9, step)]
    return np.array(lines)


class _Scene:
    """A matplotlib axes showing one skeleton; `draw(frame)` updates it."""

    def __init__(self, ax, motion: Motion, follow: bool = True, yaw_deg: float | None = None) -> None:
        from matplotlib.collections import LineCollection

        self.motion = motion
        self.ax = ax
        self.cam = _camera(yaw_deg)
        self.screen = project(motion.positions, self.cam)  # (T, J, 2)
        self.parents = motion.parents
        self.follow = follow
        colors = _bone_colors(motion)
        self.bones = [(j, p) for j, p in enumerate(self.parents) if p >= 0]
        self.height = max(motion.body_height_m(), 0.5)
        root = motion.positions[:, 0][:, [0, 2]]
        span = np.ptp(root, axis=0).max()
        self.half = 0.75 * self.height + (0 if follow else span / 2)
        margin = 1.5 * self.height
        floor = _floor_segments(root.min(axis=0) - margin, root.max(axis=0) + margin, 0.5)
        floor_2d = project(floor, self.cam)
        self.floor = LineCollection(floor_2d, colors="#c9c9c9", linewidths=0.6, zorder=0)
        ax.add_collection(self.floor)
        self.lines = LineCollection(np.zeros((len(self.bones), 2, 2)), colors=[colors[j] for j, _ in self.bones],
                                    linewidths=3.0, capstyle="round", zorder=2)
        ax.add_collection(self.lines)
        (self.dots,) = ax.plot([], [], "o", color="#222222", markersize=2.5, zorder=3)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        for spine in ax.spines.values():
            spine.set_visible(False)

    def draw(self, frame: int, title: str | None = None) -> None:
        pts = self.screen[frame]
        segs = np.stack([np.stack([pts[j], pts[p]]) for j, p in self.bones])
        self.lines.set_segments(segs)
        self.dots.set_data(pts[:, 0], pts[:, 1])
        # keep the body centred: follow the pelvis, looking slightly below it
        centre = self.motion.positions[frame, 0].copy() if self.follow else \
            self.motion.positions[:, 0].mean(axis=0)
        centre[1] = max(centre[1] - 0.08 * self.height, 0.25 * self.height)
        c = project(centre, self.cam)
        h = self.half
        self.ax.set_xlim(c[0] - h, c[0] + h)
        self.ax.set_ylim(c[1] - 0.62 * h * 1.45, c[1] + 0.62 * h * 1.75)
        if title is not None:
            self.ax.set_title(title, fontsize=8)


def _check(motion: Motion) -> None:
    if not motion.is_finite():
        raise ValidationError("the motion has non-finite positions or rotations", field="positions")


def gif_step(motion: Motion, fps: float | None = None) -> tuple[int, bool]:
    """(every how many frames the GIF shows one, whether MAX_GIF_FRAMES rather than the frame
    rate set it). The GIF plays at motion.fps / step: as long as the motion."""
    out_fps = min(motion.fps, GIF_MAX_FPS) if fps is None else float(fps)
    by_rate = max(1, int(round(motion.fps / out_fps)))
    by_count = math.ceil(motion.n_frames / MAX_GIF_FRAMES)
    return max(by_rate, by_count), by_count > by_rate


def render_gif(motion: Motion, path: str | Path, fps: float | None = None, size_px: int = 360,
               yaw_deg: float | None = None) -> Path:
    """Write the skeleton animation as a GIF (written atomically): at most GIF_MAX_FPS frames
    per second and MAX_GIF_FRAMES frames in all, evenly spaced (`gif_step`).

    `yaw_deg`: camera azimuth from the body's front toward its left
    (default CAMERA_YAW_DEG; -90 = seen from the right side).
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    _check(motion)
    check_render_options(yaw_deg=yaw_deg)
    step, _ = gif_step(motion, fps)
    frames = list(range(0, motion.n_frames, step))
    fig, ax = plt.subplots(figsize=(size_px / 100, size_px / 100), dpi=100)
    try:
        scene = _Scene(ax, motion, yaw_deg=yaw_deg)
        fig.subplots_adjust(left=0.02, right=0.98, bottom=0.02, top=0.9)
        writer = _gif_writer(motion.fps / step)
        with atomic_path(path, suffix=".gif") as tmp, writer.saving(fig, str(tmp), dpi=fig.dpi):
            for frame in frames:
                with stops_held():  # a stop lands between frames, not inside matplotlib's C++ drawing
                    scene.draw(frame, _title(motion, frame))
                    writer.grab_frame()
    finally:
        plt.close(fig)
    return Path(path)


def _gif_writer(fps: float):
    """matplotlib's PillowWriter, less the GIF of the frames drawn so far when the drawing stops
    (Ctrl-C, SIGTERM, an error): matplotlib writes it on the way out of an error too, seconds of
    work for a file that is thrown away, and with no frame yet its IndexError hid the stop."""
    from matplotlib.animation import PillowWriter

    class GifWriter(PillowWriter):
        stopped = False

        @contextlib.contextmanager
        def saving(self, *args, **kwargs):
            with super().saving(*args, **kwargs):
                try:
                    yield self
                except BaseException:
                    self.stopped = True
                    raise

        def finish(self) -> None:
            if not self.stopped:
                super().finish()

    return GifWriter(fps=fps)


def keyframe_indices(motion: Motion, n: int = 6) -> np.ndarray:
    """`n` frames that show the motion's range: the first frame, then repeatedly the frame whose
    pelvis-relative pose is farthest from those already chosen (in time order).

    Evenly spaced frames of a repetitive motion can all fall on the same phase (six frames of
    five curls showed the arm down six times); these show different phases.
    """
    rel = motion.positions - motion.positions[:, :1]
    flat = rel.reshape(motion.n_frames, -1)
    chosen = [0]
    dist = np.linalg.norm(flat - flat[0], axis=1)
    while len(chosen) < min(n, motion.n_frames):
        k = int(np.argmax(dist))
        if dist[k] <= 0:
            break
        chosen.append(k)
        dist = np.minimum(dist, np.linalg.norm(flat - flat[k], axis=1))
    return np.array(sorted(chosen))


def render_keyframes(motion: Motion, path: str | Path, n: int = 6, panel_px: int = 220,
                     yaw_deg: float | None = None) -> Path:
    """Write a strip of `n` keyframes (`keyframe_indices`: different poses, in time order) as an
    image in the format its suffix names (PNG, SVG, PDF, ...; written atomically). A motion with
    fewer distinct poses gives fewer panels."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    _check(motion)
    check_render_options(n, yaw_deg)
    check_image_path(path)
    frames = keyframe_indices(motion, n)
    n = len(frames)
    fig, axes = plt.subplots(1, n, figsize=(n * panel_px / 100, 1.25 * panel_px / 100), dpi=100)
    axes = np.atleast_1d(axes)
    try:
        for ax, frame in zip(axes, frames, strict=True):
            scene = _Scene(ax, motion, yaw_deg=yaw_deg)
            scene.draw(int(frame), f"{frame / motion.fps:.2f} s")
        fig.suptitle(_title(motion, int(frames[-1])).rsplit(" | frame", 1)[0], fontsize=10)
        fig.subplots_adjust(left=0.01, right=0.99, bottom=0.02, top=0.84, wspace=0.05)
        return write_figure(fig, path)
    finally:
        plt.close(fig)
