"""`vsmp-imu video ...` (frames, info, pose, source pools) and `vsmp-imu smp extract`.

`smp extract` lives here because it needs the video side; it is added to the
`smp` group (`vsmp_imu.cli.smp.smp_app`) when this module is imported.
"""

from __future__ import annotations

import contextlib
import json
import re
from pathlib import Path
from typing import Any

import typer
from rich.table import Table

from vsmp_imu.cli.common import (
    LIBRARY_OPTION,
    console,
    console_err,
    distinct_files,
    finite_range,
    library_dirs,
    option_names,
    output_dir,
    output_file,
    output_suffix,
    shown,
)
from vsmp_imu.cli.smp import smp_app, smp_suffix
from vsmp_imu.errors import ConfigError, ExtractionError, InputFileError
from vsmp_imu.io import write_json, write_text
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M, SKELETON_HEIGHT_M
from vsmp_imu.progress import progress

video_app = typer.Typer(help="Video inspection: probe clips, sample frames, pose tracks, "
                        "filter source clip pools.", no_args_is_help=True)

EXTRACTORS = ("vlm", "pose", "fused")
CHECKERS = ("pose", "vlm")
BASE_URL_OPTION = typer.Option(None, "--vlm-base-url", help="OpenAI-compatible endpoint, e.g. "
                               "https://api.openai.com/v1 or http://localhost:8000/v1 (vLLM)")
MODEL_OPTION = typer.Option(None, "--vlm-model", help="Model name served by the endpoint")
CACHE_OPTION = typer.Option(None, "--cache-dir", help="VLM response cache (default: the vlm folder "
                            "of the project's cache, see `vsmp-imu cache info`)")


def _sampler(n_frames: int | None, preset: str | None, size_px: int = 512, n_option: str = "--n"):
    """The frame sampler, range-checked; errors name `n_option`, the option that gave n_frames."""
    from vsmp_imu.extract.frames import FrameSampler
    from vsmp_imu.extract.frames import preset as get_preset

    if preset is not None:
        get_preset(preset)  # a clear error for an unknown name
    sampler = FrameSampler(n_frames=n_frames, preset=preset, size_px=size_px)
    with option_names({"n_frames": n_option, "size_px": "--size"}):
        sampler.settings()  # range checks before a clip is opened
    return sampler


def _max_fps(value: float) -> None:
    from vsmp_imu.extract.landmarks import check_max_fps

    check_max_fps(value, "--max-fps")


def _short_enough(video: Path) -> None:
    """Refuse, before any frame is tracked, a clip longer than a motion may last."""
    from vsmp_imu.extract.frames import header_duration_s
    from vsmp_imu.motion.motion import MAX_DURATION_S

    seconds = header_duration_s(video)
    if seconds is not None and seconds > MAX_DURATION_S:
        raise InputFileError(f"the clip lasts {seconds:.0f} s, longer than a motion may last", file=video,
                             allowed=f"a clip of at most {MAX_DURATION_S:g} s (cut a part first, e.g. "
                             f"`ffmpeg -ss START -t {MAX_DURATION_S:g} -i IN OUT`)")


def _client(base_url: str | None, model: str | None, cache_dir: Path | None, no_cache: bool,
            timeout_s: float, max_retries: int, no_response_format: bool):
    from vsmp_imu.extract.client import VLMClient
    from vsmp_imu.har.cache import vlm_dir

    if not base_url or not model:
        raise ConfigError("the VLM needs --vlm-base-url and --vlm-model (the key is read from "
                          "VSMP_VLM_API_KEY or OPENAI_API_KEY)", field="--vlm-base-url")
    if not no_cache:  # a cache folder that cannot be written fails before a paid request, not after
        output_dir(cache_dir, "--cache-dir")
    cache = None if no_cache else (cache_dir or vlm_dir())
    with option_names({"base_url": "--vlm-base-url", "timeout_s": "--timeout-s", "max_retries": "--max-retries"}):
        return VLMClient(base_url, model, timeout_s=timeout_s, max_retries=max_retries,
                         cache_dir=cache, use_response_format=not no_response_format)


def _library(library: list[Path] | None):
    from vsmp_imu.smp.library import ActivityLibrary

    return ActivityLibrary.load(library_dirs(library))


def side_paths(output: Path) -> tuple[Path, Path]:
    """(raw folder, report file) next to an SMP output: SMP.raw/ and SMP.report.json."""
    stem = output.name[: -len(output.suffix)] if output.suffix else output.name
    return output.with_name(stem + ".raw"), output.with_name(stem + ".report.json")


_RAW_FILE = re.compile(r"response_\d+\.(?:txt|json)")


def clear_earlier_run(output: Path) -> bool:
    """Remove what an earlier run wrote for `output`: the SMP, the report and SMP.raw/'s
    response files (other files there are kept). True when there was an SMP."""
    raw_dir, report_path = side_paths(output)
    if raw_dir.is_dir():
        for path in raw_dir.iterdir():
            if _RAW_FILE.fullmatch(path.name) and path.is_file():
                path.unlink()
        with contextlib.suppress(OSError):
            raw_dir.rmdir()  # only when nothing else is there
    report_path.unlink(missing_ok=True)
    had_smp = output.is_file()
    output.unlink(missing_ok=True)
    return had_smp


def write_raw(raw_dir: Path, queries: list[dict[str, Any]]) -> None:
    """One text file per response (as received) and one JSON file per full response or error."""
    raw_dir.mkdir(parents=True, exist_ok=True)
    for q in queries:
        k = q["index"]
        if q.get("content") is not None:
            write_text(raw_dir / f"response_{k}.txt", q["content"])
        write_json(raw_dir / f"response_{k}.json",
                   q.get("response") if q.get("response") is not None
                   else {"error": q.get("error"), "errors": q.get("errors", [])})


# -- smp extract ------------------------------------------------------------------------
@smp_app.command("extract")
def extract_cmd(
    video: Path = typer.Argument(..., help="Video clip"),
    label: str = typer.Option(..., "--label", help="The clip's activity label (a library name "
                              "or alias, or free text)"),
    extractor: str = typer.Option("vlm", "--extractor", help="vlm | pose | fused"),
    output: Path | None = typer.Option(None, "-o", "--output", help="SMP file to write (.json/.yaml); "
                                       "SMP.raw/ and SMP.report.json are written next to it"),
    n_queries: int = typer.Option(5, "--n-queries", help="VLM queries per clip, 3..20"),
    n_frames: int | None = typer.Option(None, "--n-frames", help="Frames sent to the VLM"),
    preset: str | None = typer.Option(None, "--preset", help="Frame preset: mm_fit, utd_mhad, "
                                      "mmact, pamap2, had_aw"),
    base_url: str | None = BASE_URL_OPTION,
    model: str | None = MODEL_OPTION,
    cache_dir: Path | None = CACHE_OPTION,
    no_cache: bool = typer.Option(False, "--no-cache", help="Do not read or write the VLM cache"),
    dry_run: bool = typer.Option(False, "--dry-run", help="Show the VLM request; send nothing"),
    no_label_hint: bool = typer.Option(False, "--no-label-hint", help="Do not tell the VLM the label"),
    no_response_format: bool = typer.Option(False, "--no-response-format",
                                            help="Never send the JSON-schema response_format"),
    timeout_s: float = typer.Option(120.0, "--timeout-s", help="Most seconds one VLM request may take, "
                                    "whole answer included (0 < s <= 3600)"),
    max_retries: int = typer.Option(4, "--max-retries", help="Retries per VLM query (0..10)"),
    fuse_threshold: float = typer.Option(0.35, "--fuse-threshold", callback=finite_range(0.0, 1.0),
                                         help="fused: measurements below this uncertainty override, 0..1"),
    max_fps: float = typer.Option(30.0, "--max-fps", help="pose: frames per second processed at most (> 0)"),
    motion_out: Path | None = typer.Option(None, "--motion-out", help="pose/fused: also write the "
                                           "clip's pose motion (.npz)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Extract the SMP of a video clip with a VLM, from body pose, or both (fused)."""
    output_file(output)
    output_file(motion_out, "--motion-out")
    report_next_to = side_paths(output)[1] if output is not None else None
    distinct_files({"--output": output, "the report next to --output": report_next_to, "--motion-out": motion_out},
                   {"the video": video})
    smp_suffix(output)
    output_suffix(motion_out, ".npz", "a motion", "--motion-out")
    _max_fps(max_fps)
    if extractor not in EXTRACTORS:
        raise ConfigError(f"unknown extractor '{extractor}'", field="--extractor",
                          allowed=", ".join(EXTRACTORS))
    if n_frames is not None and preset is not None:
        raise ConfigError("give --n-frames or --preset, not both", field="--n-frames")
    if output is None and not dry_run:
        raise ConfigError("name the SMP file to write with -o", field="--output")
    if output is not None:
        raw_next_to, _ = side_paths(output)
        output_dir(raw_next_to, "the raw folder next to --output")
        output_file(report_next_to, "the report next to --output")
    lib = _library(library)
    if motion_out is not None:
        _short_enough(video)
    use_vlm = extractor == "vlm" or (extractor == "fused" and base_url is not None)
    vlm = None
    if use_vlm:
        from vsmp_imu.extract.vlm import VLMExtractor

        client = _client(base_url, model, cache_dir, no_cache, timeout_s, max_retries,
                         no_response_format)
        vlm = VLMExtractor(client, n_queries=n_queries, sampler=_sampler(n_frames, preset, n_option="--n-frames"),
                           library=lib, label_hint=not no_label_hint)
        _check_vlm(vlm)
    if dry_run:
        if vlm is None:
            typer.echo(json.dumps({"extractor": extractor, "video": str(video), "label": label,
                                   "note": "the pose extractor sends no request"}, indent=2))
            return
        typer.echo(json.dumps(vlm.preview(video, label), indent=2))
        return
    assert output is not None
    raw_dir, report_path = side_paths(output)
    report: dict[str, Any] = {}
    smp = None
    if vlm is not None:
        with progress(f"VLM queries ({vlm.client.model})", n_queries) as update:
            result = vlm.extract(video, label, progress=update)
        had_smp = clear_earlier_run(output)
        write_raw(raw_dir, result.queries)
        report = result.to_dict()
        c = result.counts
        console.print(f"VLM: {c.valid}/{c.queries} valid responses ({c.cached} cached, "
                      f"{c.request_failures} request failures, {c.malformed_json} malformed JSON, "
                      f"{c.missing_mandatory_field} missing mandatory, {c.invalid_value} invalid "
                      f"values, {c.repaired} repaired); {c.corrections} refinement correction(s)",
                      highlight=False)
        if result.smp is None and extractor == "vlm":
            write_json(report_path, report)
            removed = f" (removed the SMP of an earlier run, {output})" if had_smp else ""
            raise ExtractionError(f"clip discarded: {result.reason}{removed}", file=video)
        smp = result.smp
        if smp is None:
            console_err.print(f"VLM discarded the clip ({shown(result.reason)}); fusing pose with the "
                              "library SMP instead", highlight=False)
    if extractor in ("pose", "fused"):
        from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
        from vsmp_imu.extract.pose import PoseExtractor

        pose = PoseExtractor(MediaPipePoseEstimator(max_fps=max_fps), library=lib)
        with progress("pose frames", None) as update:
            extraction = pose.extract(video, label, base=smp,
                                      mode="replace" if extractor == "pose" else "fuse",
                                      threshold=fuse_threshold, progress=update)
        if extractor == "pose":
            report = extraction.to_dict()
        else:
            report = {**report, "extractor": "fused", "pose": extraction.to_dict()}
        smp = extraction.smp
        _print_pose(extraction)
        if motion_out is not None and extraction.motion is not None:
            extraction.motion.save(motion_out)
            console.print(f"wrote {shown(motion_out)}", highlight=False)
    assert smp is not None
    from vsmp_imu.smp import save_smp

    if vlm is None:
        clear_earlier_run(output)

    report["smp"] = smp.model_dump(mode="json")
    save_smp(smp, output)
    write_json(report_path, report)
    console.print(f"wrote {shown(output)} and {shown(report_path.name)}", highlight=False)


def _check_vlm(vlm: Any) -> None:
    """The extractor's range checks, before any request, naming the options."""
    with option_names({"n_queries": "--n-queries"}):
        vlm.check()


def _print_pose(extraction: Any) -> None:
    m = extraction.measurements
    ev = m.evidence
    q = f"{ev.quality:.2f}" if ev is not None else "n/a"
    console.print(f"pose: {extraction.track.summary()['frames_with_pose']}/"
                  f"{extraction.track.n_frames} frames with a person, window {m.window}, "
                  f"track quality {q}", highlight=False)
    table = Table(title="measured fields")
    for col in ("field", "value", "uncertainty", "action", "note"):
        table.add_column(col, overflow="fold")
    actions = {c.field: c.action for c in extraction.changes}
    for name, meas in m.fields.items():
        table.add_row(shown(name), shown(json.dumps(meas.value)), f"{meas.uncertainty:.2f}",
                      shown(actions.get(name, "")), shown(meas.note))
    console.print(table)
    for w in extraction.warnings:
        console_err.print(f"[yellow]warning:[/] {shown(w)}", highlight=False)


# -- video commands -------------------------------------------------------------------------
@video_app.command("info")
def info_cmd(video: Path = typer.Argument(..., help="Video clip")) -> None:
    """Decode a clip once and print what it holds (and what its header claims)."""
    from vsmp_imu.extract.frames import probe

    info = probe(video)
    table = Table(title=shown(video))
    table.add_column("property")
    table.add_column("value")
    for key, value in info.to_dict().items():
        table.add_row(key, shown(value))
    console.print(table)


@video_app.command("frames")
def frames_cmd(
    video: Path = typer.Argument(..., help="Video clip"),
    n: int | None = typer.Option(None, "--n", help="Frames to sample (default 16, or the preset's)"),
    preset: str | None = typer.Option(None, "--preset", help="mm_fit, utd_mhad, mmact, pamap2, had_aw"),
    size_px: int = typer.Option(512, "--size", help="Side of the letterboxed frames (px), 16..2048"),
    output: Path = typer.Option(..., "-o", "--output", help="Folder for the PNGs and contact sheet"),
) -> None:
    """Sample frames as the extractor does; write PNGs, a contact sheet and frames.json."""
    output_dir(output)
    from vsmp_imu.extract.frames import write_frames

    sampled = _sampler(n, preset, size_px).sample(video)
    write_frames(sampled, output)
    console.print(f"wrote {sampled.n_frames} frames and contact_sheet.png to {shown(output)} "
                  f"({sampled.duration_s:.2f} s clip at {sampled.fps:.3f} fps)", highlight=False)
    for w in sampled.warnings:
        console_err.print(f"[yellow]warning:[/] {shown(w)}", highlight=False)


@video_app.command("pose")
def pose_cmd(
    video: Path = typer.Argument(..., help="Video clip"),
    output: Path = typer.Option(..., "-o", "--output", help="Motion file to write (.npz)"),
    max_fps: float = typer.Option(30.0, "--max-fps", help="Frames per second processed at most (> 0)"),
    window: str = typer.Option("all", "--window", help="all: the whole clip; longest: the longest "
                               "run of one tracked person"),
    height_m: float = typer.Option(DEFAULT_HEIGHT_M, "--height-m", callback=finite_range(*SKELETON_HEIGHT_M),
                                   help=f"Body height of the skeleton (m), "
                                        f"{SKELETON_HEIGHT_M[0]:g}..{SKELETON_HEIGHT_M[1]:g}"),
) -> None:
    """MediaPipe pose -> SMPL-22 motion (.npz), gaps marked in its meta."""
    output_file(output)
    distinct_files({"--output": output}, {"the video": video})
    output_suffix(output, ".npz", "a motion")
    from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
    from vsmp_imu.extract.posemeasure import longest_run
    from vsmp_imu.extract.retarget import track_to_motion

    if window not in ("all", "longest"):
        raise ConfigError(f"unknown window '{window}'", field="--window", allowed="all, longest")
    _max_fps(max_fps)
    _short_enough(video)
    with progress("pose frames", None) as update:
        track = MediaPipePoseEstimator(max_fps=max_fps).estimate(video, update)
    if window == "longest":
        run = longest_run(track)
        if run is not None:
            track = track.slice(*run)
    motion = track_to_motion(track, height_m=height_m)
    if motion is None:
        raise ExtractionError("no person detected in the clip", file=video)
    motion.save(output)
    console.print(f"wrote {shown(output)}: {motion.n_frames} frames at {motion.fps:g} fps, person in "
                  f"{motion.meta['detected_fraction']:.0%} of them", highlight=False)


@video_app.command("pool")
def pool_cmd(
    pool_dir: Path = typer.Argument(..., help="Folder POOL/<activity>/<clip>"),
    checker: str = typer.Option("pose", "--checker", help="pose | vlm"),
    threshold: float = typer.Option(0.6, "--threshold", callback=finite_range(0.0, 1.0),
                                    help="Minimum confidence to retain a clip, 0..1"),
    output: Path = typer.Option(..., "-o", "--output", help="Manifest to write (.json)"),
    n_frames: int | None = typer.Option(None, "--n-frames", help="vlm: frames per clip"),
    base_url: str | None = BASE_URL_OPTION,
    model: str | None = MODEL_OPTION,
    cache_dir: Path | None = CACHE_OPTION,
    no_cache: bool = typer.Option(False, "--no-cache", help="Do not read or write the VLM cache"),
    timeout_s: float = typer.Option(120.0, "--timeout-s", help="Most seconds one VLM request may take, "
                                    "whole answer included (0 < s <= 3600)"),
    max_retries: int = typer.Option(4, "--max-retries", help="Retries per VLM request (0..10)"),
    max_fps: float = typer.Option(15.0, "--max-fps", help="pose: frames per second processed at most (> 0)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Filter a pool of candidate source clips; write the shared manifest."""
    output_file(output)
    from vsmp_imu.extract.pool import PoseClipChecker, SourcePoolFilter, VLMClipChecker, pool_clips

    if checker not in CHECKERS:
        raise ConfigError(f"unknown checker '{checker}'", field="--checker", allowed=", ".join(CHECKERS))
    _max_fps(max_fps)
    distinct_files({"--output": output}, {"a clip of POOL": [clip for _, clip in pool_clips(pool_dir)]})
    output_suffix(output, ".json", "a pool manifest")
    if checker == "vlm":
        client = _client(base_url, model, cache_dir, no_cache, timeout_s, max_retries, True)
        chk: Any = VLMClipChecker(client, _sampler(n_frames, None, n_option="--n-frames"))
    else:
        from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
        from vsmp_imu.extract.pose import PoseExtractor

        chk = PoseClipChecker(PoseExtractor(MediaPipePoseEstimator(max_fps=max_fps),
                                            library=_library(library)))
    with progress(f"{checker} check", None) as update:
        data = SourcePoolFilter(chk, threshold).filter(pool_dir, progress=update)
    write_json(output, data)
    table = Table(title=f"source pool ({data['counts']['retained']} of {data['counts']['clips']} retained)")
    for col in ("activity", "clip", "decision", "confidence", "reason"):
        table.add_column(col, overflow="fold")
    for c in data["clips"]:
        table.add_row(shown(c["activity"]), shown(c["path"]), c["decision"], f"{c['confidence']:.2f}",
                      shown(c["reason"]))
    console.print(table)
    console.print(f"wrote {shown(output)}", highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(video_app, name="video")
