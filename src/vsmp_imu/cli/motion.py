"""`vsmp-imu motion ...`: synthesize, draw, export and inspect motions."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from rich.table import Table

from vsmp_imu.cli.common import (
    LIBRARY_OPTION,
    console,
    distinct_files,
    finite_range,
    library_dirs,
    naming,
    option_names,
    output_file,
    output_suffix,
    shown,
)
from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.io import check_image_path

motion_app = typer.Typer(help="Motions: synthesize from an SMP or a prompt (procedural or HY-Motion), "
                         "render, export to BVH, inspect, resample.", no_args_is_help=True)


def _library(library: list[Path] | None):
    from vsmp_imu.smp.library import ActivityLibrary

    return ActivityLibrary.load(extra_dirs=library_dirs(library))


def _smp_file(source: str | None) -> Path | None:
    """The SMP file `source` names, or None for an activity name."""
    if source is None:
        return None
    path = Path(source)
    return path if path.suffix.lower() in (".json", ".yaml", ".yml") or path.exists() else None


def _read_smp(source: str, library):
    """(SMP, library): an SMP from a file, or the library SMP of an activity name. An activity file
    joins the library, so that its `procedural:` recipe, if any, performs it."""
    from vsmp_imu.smp.io import load_smp_or_activity
    from vsmp_imu.smp.library import ActivityLibrary

    path = _smp_file(source)
    if path is not None:
        smp, entry = load_smp_or_activity(path)
        return smp, (library if entry is None else ActivityLibrary([*library, entry]))
    try:
        return library.get(source).smp, library
    except ValidationError as exc:
        raise ValidationError(f"'{source}' is neither an SMP file nor a library activity ({exc.message})",
                              field="SMP", allowed="an .json/.yaml SMP file or an activity name "
                              "(vsmp-imu smp library list)") from None


def _load_motion(path: Path):
    from vsmp_imu.motion import Motion

    return Motion.load(path)


@motion_app.command("synth")
@option_names({"backend": "--backend", "model_path": "--model-path"})
def synth_cmd(
    smp: str = typer.Argument(None, help="SMP file (.json/.yaml), activity file or activity name; "
                              "optional with --prompt"),
    seed: int = typer.Option(..., "--seed", help="generation seed (same seed, same bytes)"),
    output: Path = typer.Option(..., "-o", "--output", help="motion file to write (.npz)"),
    duration_s: float = typer.Option(None, "--duration-s", callback=finite_range(0.1, 600.0),
                                    help="duration in seconds, 0.1..600 (default: natural)"),
    backend: str = typer.Option("procedural", "--backend", help="procedural | compiled | hymotion"),
    prompt: str = typer.Option(None, "--prompt", help="free-text prompt instead of (or overriding) the SMP"),
    library: list[Path] = LIBRARY_OPTION,
    fps: float = typer.Option(30.0, "--fps", callback=finite_range(1.0, 1000.0),
                              help="frame rate of the procedural backend, 1..1000"),
    model_path: str = typer.Option(None, "--model-path", help="HY-Motion checkpoint folder"),
) -> None:
    """Generate one motion and write it as .npz."""
    output_file(output)
    distinct_files({"--output": output}, {"the input SMP": _smp_file(smp)})
    output_suffix(output, ".npz", "a motion")
    from vsmp_imu.motion import get_backend

    if smp is None and prompt is None:
        raise ConfigError("give an SMP (file or activity name) or --prompt", field="SMP")
    source, lib = (prompt, _library(library)) if prompt is not None else _read_smp(smp, _library(library))
    name = backend.strip().lower()
    kwargs = {"library": lib}
    if name in ("procedural", "compiled"):
        kwargs["fps"] = fps
    elif model_path is not None:
        kwargs["model_path"] = model_path
    engine = get_backend(backend, **kwargs)
    smp_file = _smp_file(smp) if prompt is None else None
    with console.status(f"[bold]synthesizing[/] with {engine.name} (seed {seed})..."), naming(smp_file):
        motion = engine.generate(source, seed=seed, duration_s=duration_s)
    motion.save(output)
    console.print(f"[green]wrote[/] {shown(output)}: {shown(motion.meta.get('activity', '?'))}, "
                  f"{motion.n_frames} frames at {motion.fps:g} fps ({motion.duration_s:.2f} s), "
                  f"backend {motion.meta.get('backend')}, seed {seed}")


@motion_app.command("render")
def render_cmd(
    motion_file: Path = typer.Argument(..., help="motion file (.npz)"),
    output: Path = typer.Option(..., "-o", "--output", help="animated GIF to write (.gif)"),
    keyframes: Path = typer.Option(None, "--keyframes", help="also write a keyframe strip (.png, .svg, "
                                   ".pdf, ...: the format its suffix names)"),
    n: int = typer.Option(6, "--n", help="number of keyframes, 1..60"),
    view: float = typer.Option(None, "--view", help="camera azimuth in degrees (-90: right side)"),
) -> None:
    """Draw the skeleton animation as a GIF (and a keyframe strip)."""
    output_file(output)
    output_file(keyframes, "--keyframes")
    distinct_files({"--output": output, "--keyframes": keyframes}, {"the input motion": motion_file})
    output_suffix(output, ".gif", "the animation")
    if keyframes is not None:
        check_image_path(keyframes, "--keyframes")
    from vsmp_imu.motion.render import (
        MAX_GIF_FRAMES,
        check_render_options,
        gif_step,
        render_gif,
        render_keyframes,
    )

    with option_names({"n": "--n", "yaw_deg": "--view"}):
        check_render_options(n, view)

    motion = _load_motion(motion_file)
    with console.status("[bold]rendering[/]..."), naming(motion_file):
        render_gif(motion, output, yaw_deg=view)
        if keyframes is not None:
            render_keyframes(motion, keyframes, n=n, yaw_deg=view)
    console.print(f"[green]wrote[/] {shown(output)}" + (f" and {shown(keyframes)}" if keyframes else ""))
    step, capped = gif_step(motion)
    if capped:
        console.print(f"[yellow]note:[/] the GIF shows {len(range(0, motion.n_frames, step))} of the "
                      f"{motion.n_frames} frames (one in {step}, {motion.fps / step:.3g} fps): a GIF holds at "
                      f"most {MAX_GIF_FRAMES} frames", highlight=False)


@motion_app.command("bvh")
def bvh_cmd(
    motion_file: Path = typer.Argument(..., help="motion file (.npz)"),
    output: Path = typer.Option(..., "-o", "--output", help="BVH file to write (.bvh)"),
    scale: float = typer.Option(1.0, "--scale", help="unit scale, 0.01..1000 (1 = metres, 100 = centimetres)"),
) -> None:
    """Export a motion as BVH (opens in Blender)."""
    output_file(output)
    distinct_files({"--output": output}, {"the input motion": motion_file})
    output_suffix(output, ".bvh", "a BVH motion")
    from vsmp_imu.motion.bvh import check_scale, write_bvh

    with option_names({"scale": "--scale"}):
        check_scale(scale)
    motion = _load_motion(motion_file)
    with naming(motion_file):
        write_bvh(motion, output, scale=scale)
    console.print(f"[green]wrote[/] {shown(output)}: {motion.n_joints} joints, {motion.n_frames} frames")


@motion_app.command("info")
def info_cmd(motion_file: Path = typer.Argument(..., help="motion file (.npz)")) -> None:
    """Show a motion's size, body and provenance."""
    motion = _load_motion(motion_file)
    table = Table(title=shown(motion_file), show_header=False)
    table.add_row("frames", f"{motion.n_frames} at {motion.fps:g} fps ({motion.duration_s:.2f} s)")
    table.add_row("joints", f"{motion.n_joints}: {shown(', '.join(motion.joint_names))}")
    table.add_row("body height", _height_text(motion))
    for key in ("backend", "seed", "activity", "activity_label", "smp_id", "prompt"):
        if motion.meta.get(key) is not None:
            table.add_row(key, shown(motion.meta[key]))
    if "controls" in motion.meta:
        table.add_row("controls", shown(json.dumps(motion.meta["controls"], sort_keys=True)))
    console.print(table)


def _height_text(motion) -> str:
    try:
        return f"{motion.body_height_m():.3f} m"
    except ValidationError:
        return "n/a (not an SMPL-22 skeleton)"


@motion_app.command("resample")
def resample_cmd(
    motion_file: Path = typer.Argument(..., help="motion file (.npz)"),
    fps: float = typer.Option(..., "--fps", callback=finite_range(1.0, 1000.0), help="new frame rate, 1..1000"),
    output: Path = typer.Option(..., "-o", "--output", help="motion file to write (.npz)"),
) -> None:
    """Write the motion at another frame rate."""
    output_file(output)
    distinct_files({"--output": output}, {"the input motion": motion_file})
    output_suffix(output, ".npz", "a motion")
    source = _load_motion(motion_file)
    with naming(motion_file), option_names({"fps": "--fps"}):
        motion = source.resample(fps)
    motion.save(output)
    console.print(f"[green]wrote[/] {shown(output)}: {motion.n_frames} frames at {motion.fps:g} fps")


def register(app: typer.Typer) -> None:
    """Attach this module's commands to the main app."""
    app.add_typer(motion_app, name="motion")
