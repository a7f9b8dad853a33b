"""`vsmp-imu imu ...`: virtual IMU sensors on a motion."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vsmp_imu.cli.common import (
    console,
    distinct_files,
    finite_range,
    naming,
    option_names,
    output_file,
    output_suffix,
    parse_csv,
    shown,
)

imu_app = typer.Typer(help="Virtual IMUs: simulate accelerometer and gyroscope readings from a "
                      "motion, plot them, list the sensor locations.", no_args_is_help=True)


MIN_SMOOTHING_HZ = 0.1  # below this the smoothing spline's system is near singular
# the simulator's settings by the options that set them
_OPTIONS = {"fs_hz": "--fs", "smoothing_hz": "--smoothing-hz", "trim_s": "--trim-s"}


@imu_app.command("simulate")
def simulate_cmd(
    motion_file: Path = typer.Argument(..., help="motion file (.npz)"),
    output: Path = typer.Option(..., "-o", "--output", help="IMU CSV to write"),
    location: str = typer.Option("waist", "--location", "-l",
                                 help="sensor location(s), comma-separated (see `imu locations`)"),
    fs: float = typer.Option(50.0, "--fs", help="output rate (Hz), 1..10000"),
    no_noise: bool = typer.Option(False, "--no-noise", help="exact kinematics: no white noise, no bias drift"),
    seed: int = typer.Option(0, "--seed", help="noise seed"),
    smoothing_hz: float = typer.Option(None, "--smoothing-hz", callback=finite_range(0.0, 1000.0),
                                       help="cutoff of the smoothing splines of positions and rotations "
                                            "(Hz; default: the placement's, 8, feet 15; 0 = interpolate)"),
    trim_s: float = typer.Option(0.2, "--trim-s", help="margin dropped at each end (s)"),
    plot: Path | None = typer.Option(None, "--plot", help="also draw the signals to this PNG"),
) -> None:
    """Simulate virtual IMU readings (m/s², rad/s) from a motion file."""
    output_file(output)
    output_file(plot, "--plot")
    distinct_files({"--output": output, "--plot": plot}, {"the input motion": motion_file})
    output_suffix(output, ".csv", "an IMU recording")
    if plot is not None:
        _image_file(plot, "--plot")
    from vsmp_imu.errors import ConfigError
    from vsmp_imu.imu import ImuSimulator, get_placement
    from vsmp_imu.imu.kinematics import PLACEMENT_CUTOFF

    if not 1.0 <= fs <= 10000.0:  # NaN fails too
        raise ConfigError(f"{fs:g} Hz is not a usable output rate", field="--fs", allowed="1..10000 Hz")
    if smoothing_hz is not None and (0 < smoothing_hz < MIN_SMOOTHING_HZ or smoothing_hz != smoothing_hz):
        raise ConfigError(f"{smoothing_hz:g} Hz is too low for the smoothing spline", field="--smoothing-hz",
                          allowed=f"0 (interpolate) or {MIN_SMOOTHING_HZ:g}..1000 Hz")
    from vsmp_imu.motion import Motion

    names = parse_csv(location, option="--location")
    placements = [get_placement(n) for n in names]
    motion = Motion.load(motion_file)
    cutoff = PLACEMENT_CUTOFF if smoothing_hz is None else smoothing_hz or None
    sim = ImuSimulator(fs, noise=not no_noise, seed=seed, smoothing_hz=cutoff, trim_s=trim_s)
    with naming(motion_file), option_names(_OPTIONS):  # e.g. a motion shorter than the --trim-s margins
        rec = sim.simulate(motion, placements[0]) if len(placements) == 1 else \
            sim.simulate_many(motion, placements)
    rec.meta["motion_file"] = str(motion_file)
    rec.save_csv(output)
    console.print(f"[green]wrote[/] {shown(output)}: {rec.n_samples} samples at {rec.fs_hz:g} Hz, "
                  f"{len(rec.channel_names)} channels ({', '.join(p.name for p in placements)})")
    if plot is not None:
        from vsmp_imu.imu.plot import plot_imu

        plot_imu(rec, plot, title=f"{motion_file.name}: {', '.join(p.name for p in placements)}")
        console.print(f"[green]wrote[/] {shown(plot)}")


@imu_app.command("plot")
def plot_cmd(
    files: list[Path] = typer.Argument(..., help="IMU CSV file(s); several are overlaid"),
    output: Path = typer.Option(..., "-o", "--output", help="PNG to write"),
    title: str | None = typer.Option(None, "--title", help="figure title"),
) -> None:
    """Plot accelerometer and gyroscope panels of one or more IMU CSV files."""
    output_file(output)
    distinct_files({"--output": output}, {"an input CSV": files})
    _image_file(output, "--output")
    from vsmp_imu.imu.plot import plot_imu

    recs = [_plottable(f) for f in files]
    labels = [f.stem for f in files] if len(files) > 1 else None
    plot_imu(recs if len(recs) > 1 else recs[0], output, title=title or ", ".join(f.name for f in files),
             labels=labels)
    console.print(f"[green]wrote[/] {shown(output)}")


def _image_file(path: Path, option: str) -> None:
    from vsmp_imu.imu.plot import check_image_path

    check_image_path(path, option)


def _plottable(file: Path):
    """The recording of an IMU CSV whose figure has a bounded number of panels."""
    from vsmp_imu.imu import read_imu_csv
    from vsmp_imu.imu.plot import check_plottable

    rec = read_imu_csv(file)
    with naming(file):
        check_plottable(rec)
    return rec


@imu_app.command("locations")
def locations_cmd() -> None:
    """List the named sensor placements, their segments and aliases."""
    from vsmp_imu.imu.placement import PLACEMENTS, aliases_of

    table = Table(title="Sensor locations", caption="Sensor frame at rest = segment frame "
                  "(x left, y up, z forward); attachment = fraction of the bone toward a joint "
                  "+ skin offset in the segment frame (m, 1.70 m body).")
    table.add_column("location", no_wrap=True, style="bold")
    table.add_column("segment", no_wrap=True)
    for col in ("attachment", "aliases", "description"):
        table.add_column(col, overflow="fold")
    for name, p in PLACEMENTS.items():
        table.add_row(name, p.segment, p.rule(), ", ".join(aliases_of(name)), p.description)
    console.print(table)


def register(app: typer.Typer) -> None:
    """Attach this module's commands to the main app."""
    app.add_typer(imu_app, name="imu")
