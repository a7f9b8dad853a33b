"""Extraction benchmarks (CPU): frame sampling, MediaPipe pose, retargeting, measurements.

Parts (`--parts`, all by default):
- frames: frame sampling of each real clip to 16 / 32 frames (decode + letterbox), seconds per clip;
- retarget: retargeting + measurement of a 10 s, 30 fps synthetic track (no MediaPipe), seconds;
- clips: MediaPipe Pose (model_complexity=1, every frame) over each real clip, frames per second
  processed, and what the pose extractor measured on it (the table of docs/extract.md).

Every part's figures go to benchmarks/results/extract_clips.json (with its command, start, wall
time, load average and machine); a part not run keeps its earlier figures. The table of
docs/extract.md is rebuilt from that record (`VIEWS` below, through `vsmp-imu report --write`).

Usage:  .venv/bin/python benchmarks/bench_extract.py [--parts frames,retarget,clips] [--videos DIR]
The clips are outside the repository: ../shared/data/videos from the checkout by default.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "extract_clips.json"
VIDEO_DIR = ROOT.parent / "shared" / "data" / "videos"
CLIPS = (("vtest.avi", "walking"), ("bikes.mp4", "cycling"), ("carphone_pristine.mp4", "sitting"))
PARTS = ("frames", "retarget", "clips")
NEEDS_VIDEOS = ("frames", "clips")


# -- measuring ------------------------------------------------------------------------------------
def measure_frames(videos: Path) -> dict:
    from vsmp_imu.extract.frames import FrameSampler

    runs = []
    for name, _ in CLIPS:
        for n in (16, 32):
            start = time.perf_counter()
            sample = FrameSampler(n_frames=n).sample(videos / name)
            wall = time.perf_counter() - start
            runs.append({"clip": name, "n_frames": n, "decoded": sample.info.n_frames, "wall_s": wall})
            print(f"frames {name:24s} N_f={n:2d}: {wall:.2f} s ({sample.info.n_frames} frames decoded, "
                  f"{sample.info.n_frames / wall:.0f} frames/s)")
    return {"runs": runs}


def measure_retarget() -> dict:
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
          f"(u={tempo.uncertainty})")
    return {"duration_s": 10.0, "fps": track.fps, "wall_s": wall, "tempo": tempo.to_dict()}


def clip_record(name: str, label: str, track, result, wall: float) -> dict:
    """What the pose extraction of one clip measured (JSON-ready)."""
    m = result.measurements.to_dict()
    source = {k: v for k, v in track.source.items() if k != "path"}  # no machine path in the record
    return {"clip": name, "label": label, "library_entry": result.entry, "generic_smp": result.generic,
            "source": source, "n_frames": track.n_frames, "fps": track.fps,
            "frames_with_pose": int(track.detected.sum()), "wall_s": wall,
            "window": m["window"], "clip_track": m["clip_track"], "track": m["track"],
            "fields": m["fields"], "warnings": list(result.warnings)}


def measure_clips(videos: Path) -> dict:
    from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
    from vsmp_imu.extract.pose import PoseExtractor

    clips = []
    for name, label in CLIPS:
        extractor = PoseExtractor(MediaPipePoseEstimator(max_fps=None))
        start = time.perf_counter()
        track = extractor.track(videos / name)
        wall = time.perf_counter() - start
        clips.append(clip_record(name, label, track, extractor.extract_track(track, label), wall))
        print(f"pose {name:24s}: {track.n_frames} frames in {wall:.1f} s ({track.n_frames / wall:.0f} frames/s)")
    return {"clips": clips}


def machine() -> dict:
    import cv2
    import mediapipe
    import numpy

    return {"cpu": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "python": platform.python_version(), "numpy": numpy.__version__,
            "mediapipe": mediapipe.__version__, "opencv": cv2.__version__}


def _measure(part: str, videos: Path) -> dict:
    if part == "frames":
        return measure_frames(videos)
    if part == "retarget":
        return measure_retarget()
    return measure_clips(videos)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated: " + ", ".join(PARTS))
    parser.add_argument("--videos", type=Path, default=VIDEO_DIR, help="the folder of the three clips")
    parser.add_argument("--json", type=Path, default=OUT, help="where to write the measurements")
    args = parser.parse_args()
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    if unknown := [p for p in parts if p not in PARTS]:
        parser.error(f"unknown part(s) {', '.join(unknown)}; choose from {', '.join(PARTS)}")
    if not args.videos.is_dir() and any(p in NEEDS_VIDEOS for p in parts):
        parser.error(f"{args.videos} not found: the frames and clips parts need the clips (--videos DIR)")
    from vsmp_imu.har.bench_records import record_parts

    record = record_parts(args.json, "benchmarks/bench_extract.py", sys.argv[1:], parts,
                          lambda part: _measure(part, args.videos), machine())
    if "clips" in record:
        print(markdown(record["clips"]))
    print(f"written: {args.json}")


# -- the table of docs/extract.md -----------------------------------------------------------------
def _value(value) -> str:
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.2f}"
    if isinstance(value, list):
        return ", ".join(_value(v).replace("_", " ") for v in value) or "none"
    if isinstance(value, dict):
        return ", ".join(f"{k} {_value(v)}" for k, v in value.items())
    return str(value)


def _level_detail(raw: dict) -> str:
    """The frequencies behind a tempo level, and the reference ratio where a level was clipped."""
    parts = []
    if raw.get("cycle_frequency_hz") is not None:
        steps = raw.get("cadence_steps_per_min")
        cadence = f" = {steps:.0f} steps/min" if steps is not None else ""
        parts.append(f"{raw['cycle_frequency_hz']:.2f} Hz by peaks{cadence}")
    if raw.get("autocorrelation_frequency_hz") is not None:
        parts.append(f"{raw['autocorrelation_frequency_hz']:.2f} Hz by autocorrelation")
    level, ratio = raw.get("level_unclipped"), raw.get("ratio_to_reference")
    if level is not None and ratio is not None and not 0.0 <= level <= 2.0:
        parts.append(f"clipped from {level:.2f}, {ratio:.1f}× the reference")
    return "; ".join(parts)


def _field(name: str, field: dict) -> str:
    label = name.replace("_", " ")
    if field["value"] is None:
        return f"{label} not measured"
    u = f"u = {field['uncertainty']:.2f}"
    if name == "global_displacement":
        return f"displacement {field['value']:.1f} m ({u})"
    if name == "periodicity":
        return f"periodic {_value(field['value'])} ({u})"
    detail = _level_detail(field["raw"]) if name in ("tempo", "amplitude") else ""
    return f"{label} {_value(field['value'])} ({u}{'; ' + detail if detail else ''})"


def _measured(clip: dict) -> str:
    fields = clip["fields"]
    if all(f["value"] is None for f in fields.values()):
        return "nothing measured (" + (next(iter(fields.values()))["note"] or "no person") + ")"
    from vsmp_imu.extract.posemeasure import FIELDS

    names = sorted(fields, key=lambda n: FIELDS.index(n) if n in FIELDS else len(FIELDS))
    generic = "generic SMP; " if clip["generic_smp"] else ""
    return generic + "; ".join(_field(name, fields[name]) for name in names)


def _window(clip: dict) -> str:
    window = clip["window"]
    if window is None:
        return "none"
    if window == [0, clip["n_frames"]]:
        return "whole clip"
    return f"{window[0]}–{window[1] - 1} ({(window[1] - window[0]) / clip['fps']:.1f} s)"


def _quality(clip: dict) -> str:
    ev = clip["track"]
    if ev is None:
        return "none"
    return (f"{ev['quality']:.2f} (body ~{ev['body_height_px']:.0f} px tall, core landmarks "
            f"{100 * ev['visibility']:.0f} % visible, {clip['fps']:g} fps)")


def clip_row(clip: dict) -> tuple[str, ...]:
    library = "" if clip["library_entry"] else ", not in the library"
    switches = clip["clip_track"]["identity_switches"] if clip["clip_track"] else 0
    return (f"`{clip['clip']}` (label {clip['label']}{library})",
            f"{clip['frames_with_pose']} / {clip['n_frames']} frames, {switches} identity switches",
            _window(clip), _quality(clip), _measured(clip))


def markdown(part: dict) -> str:
    lines = ["| clip | person found | window (frames) | track quality | what was measured |",
             "| --- | --- | --- | --- | --- |"]
    lines += ["| " + " | ".join(clip_row(c)) + " |" for c in part["clips"]]
    return "\n".join(lines) + "\n"


def _speeds(record: dict) -> str:
    clips = record["clips"]["clips"]
    pose = [c["n_frames"] / c["wall_s"] for c in clips]
    text = (f"MediaPipe {record['clips']['machine']['mediapipe']}, every frame: "
            f"{min(pose):.0f}–{max(pose):.0f} frames/s")
    if "frames" in record:
        runs = record["frames"]["runs"]
        rates = [r["decoded"] / r["wall_s"] for r in runs]
        text += f"; frame sampling {min(rates):.0f}–{max(rates):.0f} decoded frames/s"
    return text


def _when(part: dict) -> str:
    load = part["load_avg_at_start"][0]
    return (f"`{part['command']}` ({part['started']}, {part['machine']['cpus']} CPUs, {part['wall_s']:.0f} s, "
            f"load average {load:.1f} at its start)")


def view_clips(record: dict) -> tuple[str, str]:
    """The table of docs/extract.md and where its figures come from (with the speeds measured)."""
    parts = [f"{name} from {_when(record[name])}" for name in ("clips", "frames") if name in record]
    return markdown(record["clips"]), f"`benchmarks/results/extract_clips.json`: {'; '.join(parts)}; {_speeds(record)}"


VIEWS = {"clips": view_clips}

if __name__ == "__main__":
    main()
