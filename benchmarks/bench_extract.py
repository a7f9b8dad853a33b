"""Extraction benchmarks (CPU): frame sampling, MediaPipe pose, retargeting, measurements.

1. Frame sampling of each real clip to 16 / 32 frames (decode + letterbox): seconds per clip.
2. MediaPipe Pose (model_complexity=1) over each real clip: frames per second processed,
   and the ratio to real time.
3. Retargeting + measurement of a 10 s, 30 fps synthetic track (no MediaPipe): seconds.
4. What the pose extractor measures on each real clip (the numbers docs/extract.md reports).

Usage:  .venv/bin/python benchmarks/bench_extract.py [--skip-pose]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

VIDEO_DIR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "videos"
CLIPS = (("vtest.avi", "walking"), ("bikes.mp4", "cycling"), ("carphone_pristine.mp4", "sitting"))


def bench_frames() -> None:
    from vsmp_imu.extract.frames import FrameSampler

    for name, _ in CLIPS:
        path = VIDEO_DIR / name
        for n in (16, 32):
            start = time.perf_counter()
            s = FrameSampler(n_frames=n).sample(path)
            wall = time.perf_counter() - start
            print(f"frames {name:24s} N_f={n:2d}: {wall:.2f} s ({s.info.n_frames} frames decoded, "
                  f"{s.info.n_frames / wall:.0f} frames/s)")


def bench_retarget() -> None:
    from vsmp_imu.extract.calibrate import motion_track
    from vsmp_imu.extract.pose import PoseExtractor
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    motion = ProceduralBackend(library).generate(library.get("walking").smp, seed=0, duration_s=10.0)
    track = motion_track(motion)
    extractor = PoseExtractor(library=library)
    extractor.extract_track(track, "walking")  # the reference is measured once and cached
    start = time.perf_counter()
    result = extractor.extract_track(track, "walking")
    wall = time.perf_counter() - start
    tempo = result.measurements.fields["tempo"]
    print(f"retarget + measure, 10 s at 30 fps: {wall:.2f} s; tempo level {tempo.value} "
          f"(u={tempo.uncertainty}), cadence {tempo.raw['cadence_steps_per_min']:.0f} steps/min")


def bench_pose() -> None:
    from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
    from vsmp_imu.extract.pose import PoseExtractor

    for name, label in CLIPS:
        path = VIDEO_DIR / name
        extractor = PoseExtractor(MediaPipePoseEstimator(max_fps=None))
        start = time.perf_counter()
        track = extractor.track(path)
        wall = time.perf_counter() - start
        result = extractor.extract_track(track, label)
        m = result.measurements
        print(f"pose {name:24s}: {track.n_frames} frames in {wall:.1f} s "
              f"({track.n_frames / wall:.0f} frames/s, {track.n_frames / track.fps / wall:.1f}x real "
              f"time); person in {int(track.detected.sum())}, window {m.window}, "
              f"track quality {m.evidence.quality:.2f}")
        for field, meas in m.fields.items():
            raw = {k: v for k, v in meas.to_dict()["raw"].items()
                   if k in ("cycle_frequency_hz", "cadence_steps_per_min", "range_of_motion_rad",
                            "c_sym", "energy_ratio", "extent_m", "strength")}
            print(f"    {field:20s} {meas.value!s:40.40s} u={meas.uncertainty:.2f} {raw}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--skip-pose", action="store_true")
    args = parser.parse_args()
    if not VIDEO_DIR.exists():
        print(f"{VIDEO_DIR} not found: frame and pose benchmarks skipped")
    else:
        bench_frames()
    bench_retarget()
    if VIDEO_DIR.exists() and not args.skip_pose:
        bench_pose()


if __name__ == "__main__":
    main()
