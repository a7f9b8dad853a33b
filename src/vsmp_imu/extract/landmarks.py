"""Per-frame body landmarks from MediaPipe Pose (the legacy `mp.solutions.pose` API).

MediaPipe 0.10.21 is the last release whose wheel bundles the pose models;
only `model_complexity=1` is available offline. It tracks one person: after
a detection it follows that person's region of interest, and re-detects
(possibly someone else) when tracking is lost.

MediaPipe's coordinate conventions (checked on `carphone_pristine.mp4`, a
man facing the camera: his left shoulder has the larger x, his nose the
smaller y and a negative z):

- `pose_landmarks` (image): x, y normalized to the frame width and height,
  x to the image right, y down; z a relative depth (smaller = closer).
- `pose_world_landmarks` (world): metres, origin midway between the hips,
  x to the image right, y down, z away from the camera (a right-handed
  frame). Landmark names are the person's own sides ("left_shoulder" is
  the person's left, seen on the image right when the person faces the camera).

`world_to_yup` turns world landmarks into this project's frame: X = x,
Y = -y, Z = -z (a 180 degree turn about X). A person facing the camera
then faces +Z with their left on +X, exactly the SMPL rest convention.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, DependencyError
from vsmp_imu.extract.frames import _header, _open, file_sha256, require_cv2

LANDMARKS: tuple[str, ...] = (
    "nose", "left_eye_inner", "left_eye", "left_eye_outer", "right_eye_inner", "right_eye",
    "right_eye_outer", "left_ear", "right_ear", "mouth_left", "mouth_right", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_pinky",
    "right_pinky", "left_index", "right_index", "left_thumb", "right_thumb", "left_hip",
    "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
    "right_heel", "left_foot_index", "right_foot_index",
)
LM = {name: i for i, name in enumerate(LANDMARKS)}
N_LANDMARKS = len(LANDMARKS)
MP_TO_YUP = np.array([1.0, -1.0, -1.0])  # MediaPipe world (x right, y down, z away) -> Y-up
ESTIMATOR_NAME = "mediapipe-pose"

Progress = Callable[[int, int], None]


def require_mediapipe() -> Any:
    """Import MediaPipe, or say how to install it."""
    try:
        import mediapipe as mp
    except ImportError as exc:
        raise DependencyError("pose extraction needs MediaPipe (the `video` extra); install it "
                              "with `pip install -e .[video]`") from exc
    return mp


def world_to_yup(world: np.ndarray) -> np.ndarray:
    """MediaPipe world landmarks (..., 3) -> the project's Y-up frame (see module docs)."""
    return np.asarray(world, dtype=float) * MP_TO_YUP


@dataclass
class PoseTrack:
    """Landmarks of the processed frames of one clip.

    world: (T, 33, 3) MediaPipe world landmarks (metres; NaN where no pose).
    image: (T, 33, 3) image landmarks (x, y normalized; NaN where no pose).
    visibility: (T, 33) in [0, 1] (0 where no pose).
    detected: (T,) a pose was found in the frame.
    frame_indices: (T,) source frame index of each processed frame.
    fps: processing frame rate (source fps / stride).
    """

    world: np.ndarray
    image: np.ndarray
    visibility: np.ndarray
    detected: np.ndarray
    frame_indices: np.ndarray
    fps: float
    frame_size: tuple[int, int]  # (width, height) of the source frames
    source: dict[str, Any] = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return int(self.detected.shape[0])

    @property
    def times_s(self) -> np.ndarray:
        return np.arange(self.n_frames) / self.fps

    @property
    def detected_fraction(self) -> float:
        return float(self.detected.mean()) if self.n_frames else 0.0

    def slice(self, start: int, stop: int) -> PoseTrack:
        """Frames start..stop-1 as a track of their own."""
        return PoseTrack(self.world[start:stop], self.image[start:stop],
                         self.visibility[start:stop], self.detected[start:stop],
                         self.frame_indices[start:stop], self.fps, self.frame_size,
                         dict(self.source, window=[int(start), int(stop)]))

    def summary(self) -> dict[str, Any]:
        vis = self.visibility[self.detected]
        return {"n_frames": self.n_frames, "fps": self.fps,
                "frames_with_pose": int(self.detected.sum()),
                "detected_fraction": round(self.detected_fraction, 4),
                "mean_visibility": round(float(vis.mean()), 4) if vis.size else 0.0,
                "frame_size": list(self.frame_size), "source": self.source}


def check_max_fps(max_fps: float | None, field: str = "max_fps") -> None:
    """A frame-rate cap is a finite number > 0 (None: every frame)."""
    if max_fps is not None and not (math.isfinite(max_fps) and max_fps > 0):
        raise ConfigError(f"{max_fps:g} frames per second cannot be a cap", field=field,
                          allowed="a finite number > 0 (frames per second)")


@dataclass(eq=False, repr=False)
class MediaPipePoseEstimator:
    """Run MediaPipe Pose over a clip's frames.

    model_complexity: 1 (the only model bundled offline in mediapipe 0.10.21).
    min_detection_confidence, min_tracking_confidence: MediaPipe thresholds.
    max_fps: frames are taken every ceil(fps / max_fps) (None: every frame).
    start_s, max_frames: process at most `max_frames` frames from `start_s`.
    static_image_mode: detect in every frame instead of tracking.
    """

    model_complexity: int = 1
    min_detection_confidence: float = 0.5
    min_tracking_confidence: float = 0.5
    max_fps: float | None = 30.0
    start_s: float = 0.0
    max_frames: int | None = None
    static_image_mode: bool = False

    def describe(self) -> dict[str, Any]:
        mp = require_mediapipe()
        return {"estimator": ESTIMATOR_NAME, "mediapipe": getattr(mp, "__version__", "?"),
                "model_complexity": self.model_complexity,
                "min_detection_confidence": self.min_detection_confidence,
                "min_tracking_confidence": self.min_tracking_confidence,
                "static_image_mode": self.static_image_mode}

    def estimate(self, video: str | Path, progress: Progress | None = None) -> PoseTrack:
        """Landmarks for the processed frames (InputFileError for an unreadable clip)."""
        if self.model_complexity != 1:
            raise ConfigError("only model_complexity=1 ships with mediapipe 0.10.21 (the others "
                              "need a download)", field="model_complexity", allowed="1")
        if self.max_frames is not None and self.max_frames < 2:
            raise ConfigError("max_frames must be at least 2", field="max_frames")
        check_max_fps(self.max_fps)
        cv2 = require_cv2()
        mp = require_mediapipe()
        path = Path(video)
        cap = _open(path)
        try:
            header_count, fps, width, height = _header(cap)
            if fps <= 0:
                fps = 30.0  # no frame rate in the header: assume 30 (reported in source)
            stride = 1 if self.max_fps is None else max(1, math.ceil(fps / self.max_fps - 1e-9))
            first = int(round(self.start_s * fps))
            total = header_count or None
            planned = None
            if total is not None:
                planned = max(0, (total - first + stride - 1) // stride)
                if self.max_frames is not None:
                    planned = min(planned, self.max_frames)
            world, image, vis, det, idx = [], [], [], [], []
            pose = mp.solutions.pose.Pose(
                static_image_mode=self.static_image_mode, model_complexity=self.model_complexity,
                smooth_landmarks=True, enable_segmentation=False,
                min_detection_confidence=self.min_detection_confidence,
                min_tracking_confidence=self.min_tracking_confidence)
            try:
                index = 0
                while cap.grab():
                    if index >= first and (index - first) % stride == 0:
                        ok, frame = cap.retrieve()
                        if ok and frame is not None:
                            height, width = frame.shape[:2]
                            w, im, v, d = _process(pose, cv2.cvtColor(frame, cv2.COLOR_BGR2RGB))
                            world.append(w)
                            image.append(im)
                            vis.append(v)
                            det.append(d)
                            idx.append(index)
                            if progress is not None:
                                progress(len(idx), planned or len(idx))
                            if self.max_frames is not None and len(idx) >= self.max_frames:
                                break
                    index += 1
            finally:
                pose.close()
        finally:
            cap.release()
        if not idx:
            from vsmp_imu.errors import InputFileError

            raise InputFileError("no frame could be decoded in the requested range", file=path)
        source = {"path": str(path), "sha256": file_sha256(path), "source_fps": fps,
                  "stride": stride, "start_frame": first, **self.describe()}
        return PoseTrack(np.array(world), np.array(image), np.array(vis), np.array(det, dtype=bool),
                         np.array(idx, dtype=np.int64), fps / stride, (int(width), int(height)),
                         source)


def _process(pose: Any, rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    result = pose.process(rgb)
    if result.pose_world_landmarks is None or result.pose_landmarks is None:
        nan = np.full((N_LANDMARKS, 3), np.nan)
        return nan, nan.copy(), np.zeros(N_LANDMARKS), False
    world = np.array([(p.x, p.y, p.z) for p in result.pose_world_landmarks.landmark])
    image = np.array([(p.x, p.y, p.z) for p in result.pose_landmarks.landmark])
    vis = np.clip(np.array([p.visibility for p in result.pose_landmarks.landmark]), 0.0, 1.0)
    return world, image, vis, True
