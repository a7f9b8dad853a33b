"""Qualitative case study of one activity (paper, appendix "Qualitative Analysis").

One figure: the source video frames (when a clip is given), the SMP (from
the pose extractor when a clip is given, else the library's) as a compact
text panel, three controlled variants (`smp.intervene`, one field each), the
skeleton keyframes of their motions and their synthetic IMU traces at the
activity's natural sensor location. The SMPs, the prompts, the motions and
the IMU recordings are written next to the figure.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu import ImuSimulator
from vsmp_imu.imu.recording import ImuRecording
from vsmp_imu.motion.backends import get_backend
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.recipe import recipe_for_entry
from vsmp_imu.motion.render import CENTER_COLOR, LEFT_COLOR, RIGHT_COLOR, keyframe_indices, project
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry
from vsmp_imu.smp.schema import SMP, UNKNOWN
from vsmp_imu.smp.verbalize import verbalize
from vsmp_imu.studies.control import imu_location

FIGURE_NAME = "case_study.png"
N_KEYFRAMES = 5
N_SOURCE_FRAMES = 6
AXIS_COLORS = ("#d62728", "#2ca02c", "#1f77b4")  # x, y, z (the imu room's plot colours)


@dataclass(frozen=True)
class Variant:
    """One controlled change: the attribute, the requested level and a short title."""

    attribute: str
    level: Any
    title: str


@dataclass
class CaseVariant:
    variant: Variant
    smp: SMP
    prompt: str
    motion: Motion
    imu: ImuRecording


@dataclass
class CaseStudyResult:
    activity: str
    source: str  # "library" or "pose extractor (CLIP)"
    smp: SMP
    location: str
    seed: int
    variants: list[CaseVariant]
    frames: np.ndarray | None = None
    frame_times_s: list[float] = field(default_factory=list)
    extraction: dict[str, Any] | None = None


def natural_location(entry: LibraryEntry) -> str:
    """Where the activity's dataset wears its sensor: UTD-MHAD's wrist or thigh, HAPT's waist,
    otherwise the right (dominant) wrist."""
    if "utd_mhad" in entry.datasets:
        return imu_location(entry.name)
    if "hapt" in entry.datasets:
        return "waist"
    return "right_wrist"


def default_variants(smp: SMP, entry: LibraryEntry) -> list[Variant]:
    """The first three applicable of: tempo fast, amplitude large, repetitions +3, central
    primitive x1.25, the other symmetry, tempo slow, amplitude small."""
    variant = set(smp.constraints.variant_fields)
    count = smp.repetition_count()
    periodic = "procedural" in entry.extras and recipe_for_entry(entry).kind == "periodic"
    other_symmetry = "asymmetric" if smp.execution_attributes.symmetry != "asymmetric" else "symmetric"
    candidates = [
        ("tempo", Variant("tempo", "fast", "tempo: fast")),
        ("amplitude", Variant("amplitude", "large", "amplitude: large")),
        ("repetition_count", Variant("repetitions", (count or 3) + 3,
                                     f"repetitions: {(count or 3) + 3}") if periodic else None),
        ("primitive_duration", Variant("duration", 1.25, f"{entry.central_primitive} x1.25")
         if entry.central_primitive else None),
        ("symmetry", Variant("symmetry", other_symmetry, f"symmetry: {other_symmetry}")),
        ("tempo", Variant("tempo", "slow", "tempo: slow")),
        ("amplitude", Variant("amplitude", "small", "amplitude: small")),
    ]
    chosen = [v for f, v in candidates if v is not None and f in variant]
    return chosen[:3]


@dataclass(eq=False, repr=False)
class CaseStudy:
    """Build the case study of one activity; `run()` returns a CaseStudyResult.

    video: a source clip (frames and the pose extractor's SMP; needs the video
    extra); seed: motion and IMU noise seed; variants: the changes (default:
    `default_variants`); location: sensor placement (default: the activity's
    natural one).
    """

    activity: str
    video: str | Path | None = None
    seed: int = 0
    variants: list[Variant] | None = None
    library: ActivityLibrary | None = None
    backend: str = "procedural"
    fs_hz: float = 50.0
    location: str | None = None

    def run(self) -> CaseStudyResult:
        library = self.library or ActivityLibrary.load()
        entry = library.get(self.activity)
        frames, times, extraction = None, [], None
        smp, source = entry.smp, "library"
        if self.video is not None:
            from vsmp_imu.extract.frames import FrameSampler
            from vsmp_imu.extract.pose import PoseExtractor

            sampled = FrameSampler(n_frames=N_SOURCE_FRAMES).sample(self.video)
            frames, times = sampled.frames, [float(t) for t in sampled.times_s]
            result = PoseExtractor(library=library).extract(self.video, entry.name)
            smp, source = result.smp, f"pose extractor, {Path(self.video).name}"
            extraction = result.report()
        variants = self.variants if self.variants is not None else default_variants(smp, entry)
        if not variants:
            raise ValidationError(f"no control applies to '{entry.name}' (its SMP lists no variant "
                                  "field)", field="variants")
        backend = get_backend(self.backend, library=library)
        location = self.location or natural_location(entry)
        out = []
        for v in variants:
            changed = intervene(smp, v.attribute, v.level, entry.central_primitive)
            motion = backend.generate(changed, seed=self.seed)
            imu = ImuSimulator(self.fs_hz, seed=self.seed).simulate(motion, location)
            out.append(CaseVariant(v, changed, verbalize(changed), motion, imu))
        return CaseStudyResult(entry.name, source, smp, location, self.seed, out, frames, times,
                               extraction)


def smp_summary(smp: SMP, width: int = 46) -> str:
    """A compact, monospace-friendly text view of an SMP."""
    t, a, o = smp.temporal_structure, smp.execution_attributes, smp.object_contact

    def word(value: Any) -> str:
        return value if isinstance(value, str) else f"{float(value):.2f}"

    contacts = [*o.objects, *o.required_contact] or ["none"]
    top_u = sorted(smp.uncertainty.model_dump().items(), key=lambda kv: -kv[1])[:3]
    lines = [
        f"label: {smp.activity_label}",
        "primitives: " + " > ".join(smp.primitive_sequence),
        "body: " + ", ".join(smp.body_parts.mandatory),
        f"repetitive: {t.is_repetitive}, count {t.repetition_count}, {t.periodicity}",
        f"tempo {word(a.tempo)}, amplitude {word(a.amplitude)}",
        f"side {a.dominant_side}, {a.symmetry}, displacement {word(a.global_displacement)}",
        "objects/contact: " + ", ".join(dict.fromkeys(contacts)),
        "variant: " + ", ".join(smp.constraints.variant_fields or ["none"]),
        "most uncertain: " + ", ".join(f"{k} {v:.2f}" for k, v in top_u),
    ]
    wrapped = []
    for line in lines:
        wrapped += textwrap.wrap(line, width, subsequent_indent="  ") or [""]
    return "\n".join(w for w in wrapped if w != UNKNOWN)


def _draw_keyframes(ax: Any, motion: Motion, n: int = N_KEYFRAMES) -> None:
    """Keyframe skeletons side by side (fixed oblique view, pelvis-centred)."""
    from matplotlib.collections import LineCollection

    frames = keyframe_indices(motion, n)
    pts = project(motion.positions[frames])  # (n, J, 2)
    height = max(motion.body_height_m(), 0.5)
    spacing = 0.75 * height
    colors = [LEFT_COLOR if nm.startswith("left") else RIGHT_COLOR if nm.startswith("right")
              else CENTER_COLOR for nm in motion.joint_names]
    bones = [(j, p) for j, p in enumerate(motion.parents) if p >= 0]
    floor = float(project(np.array([0.0, 0.0, 0.0]))[1])
    for k, frame in enumerate(frames):
        p = pts[k] + np.array([k * spacing - pts[k, 0, 0], 0.0])
        segs = [np.stack([p[j], p[q]]) for j, q in bones]
        ax.add_collection(LineCollection(segs, colors=[colors[j] for j, _ in bones], linewidths=2.4,
                                         capstyle="round"))
        ax.text(k * spacing, floor - 0.06 * height, f"{frame / motion.fps:.1f} s", ha="center",
                va="top", fontsize=7.5, color="#555555")
    ax.plot([-0.45 * spacing, (len(frames) - 0.55) * spacing], [floor, floor], color="#cccccc",
            lw=0.8, zorder=0)
    ax.set_xlim(-0.5 * spacing, (len(frames) - 0.5) * spacing)
    ax.set_ylim(floor - 0.2 * height, floor + 1.15 * height)
    ax.set_aspect("equal")
    ax.axis("off")


def _draw_imu(ax_acc: Any, ax_gyr: Any, rec: ImuRecording) -> None:
    t = rec.times
    for i, axis in enumerate("xyz"):
        ax_acc.plot(t, rec.data[:, i], color=AXIS_COLORS[i], lw=0.9, label=axis)
        ax_gyr.plot(t, rec.data[:, 3 + i], color=AXIS_COLORS[i], lw=0.9, label=axis)
    ax_acc.set_ylabel("acc (m/s²)", fontsize=8)
    ax_gyr.set_ylabel("gyr (rad/s)", fontsize=8)
    ax_gyr.set_xlabel("time (s)", fontsize=8)
    for ax in (ax_acc, ax_gyr):
        ax.tick_params(labelsize=7)
        ax.spines[["top", "right"]].set_visible(False)
        ax.grid(color="#eeeeee", lw=0.5)
    ax_acc.tick_params(labelbottom=False)


def case_figure(result: CaseStudyResult, path: str | Path) -> Path:
    """The case-study figure (one PNG)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.gridspec import GridSpec

    from vsmp_imu.studies.report import save_figure

    n = len(result.variants)
    has_video = result.frames is not None
    top_height = 1.2 if has_video else 0.8
    fig = plt.figure(figsize=(15, 2.6 * top_height + 2.6 * n))
    heights = [top_height] + [1.0] * n
    grid = GridSpec(1 + n, 3, figure=fig, width_ratios=[0.95, 1.75, 1.3], height_ratios=heights,
                    hspace=0.42, wspace=0.1, top=1 - 0.75 / fig.get_figheight(), bottom=0.05,
                    left=0.02, right=0.98)
    # source frames (or a note) across the first two columns, SMP text on the right
    top = grid[0, :2].subgridspec(1, N_SOURCE_FRAMES if has_video else 1, wspace=0.04)
    if has_video:
        for k in range(min(N_SOURCE_FRAMES, len(result.frames))):
            ax = fig.add_subplot(top[0, k])
            ax.imshow(result.frames[k])
            ax.set_title(f"{result.frame_times_s[k]:.1f} s", fontsize=7)
            ax.axis("off")
            if k == 0:
                ax.text(-0.05, 1.25, "source video", transform=ax.transAxes, fontsize=10,
                        fontweight="bold", va="bottom")
    else:
        ax = fig.add_subplot(top[0, 0])
        ax.axis("off")
        ax.text(0.0, 0.5, "no source video: the SMP is the activity library's\n"
                f"motions: procedural backend, seed {result.seed}\n"
                f"IMU: {result.location}, {result.variants[0].imu.fs_hz:g} Hz, raw (not grounded)\n"
                "skeletons: left side blue, right side red; keyframes chosen to span the motion",
                fontsize=10, va="center", linespacing=1.6)
    ax = fig.add_subplot(grid[0, 2])
    ax.axis("off")
    ax.set_title(f"SMP ({result.source})", fontsize=10, loc="left", fontweight="bold")
    ax.text(0.0, 1.0, smp_summary(result.smp), family="monospace", fontsize=7.2, va="top",
            transform=ax.transAxes,
            bbox={"boxstyle": "round,pad=0.5", "facecolor": "#f7f7f7", "edgecolor": "#cccccc"})
    for row, var in enumerate(result.variants, start=1):
        ax = fig.add_subplot(grid[row, 0])
        ax.axis("off")
        prompt = "\n".join(textwrap.wrap(var.prompt, 44)[:9])
        ax.text(0.0, 1.0, f"variant {row}: {var.variant.title}", fontsize=10, fontweight="bold",
                va="top", transform=ax.transAxes)
        ax.text(0.0, 0.82, prompt, fontsize=7, va="top", transform=ax.transAxes, color="#333333")
        _draw_keyframes(fig.add_subplot(grid[row, 1]), var.motion)
        sub = grid[row, 2].subgridspec(2, 1, hspace=0.08)
        ax_acc, ax_gyr = fig.add_subplot(sub[0]), fig.add_subplot(sub[1])
        _draw_imu(ax_acc, ax_gyr, var.imu)
        if row == 1:
            ax_acc.legend(ncol=3, fontsize=7, frameon=False, loc="lower right",
                          bbox_to_anchor=(1.0, 1.0), handlelength=1.2)
            ax_acc.set_title(f"synthetic IMU, {result.location}", fontsize=9, loc="left")
    fig.suptitle(f"Case study: {result.activity}", fontsize=13, fontweight="bold",
                 y=1 - 0.12 / fig.get_figheight())
    return save_figure(fig, path, dpi=150)


def write_case_outputs(result: CaseStudyResult, out_dir: str | Path) -> dict[str, Path]:
    """Figure, SMPs (base and variants), prompts, motions, IMU CSVs, report.md and results.json."""
    from vsmp_imu.io import write_text
    from vsmp_imu.smp import save_smp
    from vsmp_imu.studies.report import markdown_table, write_report

    out = Path(out_dir)
    figure = case_figure(result, out / FIGURE_NAME)
    save_smp(result.smp, out / "smp.json")
    prompts = [f"base: {verbalize(result.smp)}"]
    rows, variants = [], []
    for k, var in enumerate(result.variants, start=1):
        stem = f"variant_{k}"
        save_smp(var.smp, out / f"{stem}.smp.json")
        var.motion.save(out / f"{stem}.npz")
        var.imu.save_csv(out / f"{stem}_{result.location}.csv")
        prompts.append(f"{stem} ({var.variant.title}): {var.prompt}")
        rows.append([stem, var.variant.title, f"{var.motion.n_frames / var.motion.fps:.2f} s",
                     var.smp.smp_id, var.prompt])
        variants.append({"name": stem, "attribute": var.variant.attribute, "level": var.variant.level,
                         "title": var.variant.title, "smp_id": var.smp.smp_id, "prompt": var.prompt,
                         "duration_s": var.motion.n_frames / var.motion.fps,
                         "imu_samples": var.imu.n_samples})
    write_text(out / "prompts.txt", "\n\n".join(prompts) + "\n")
    md = "\n".join([
        f"# Case study: {result.activity}", "",
        f"SMP from the {result.source}; seed {result.seed}; IMU at {result.location} "
        f"({result.variants[0].imu.fs_hz:g} Hz, raw simulator output).", "",
        f"![case study]({FIGURE_NAME})", "",
        markdown_table(["Variant", "Change", "Duration", "SMP id", "Prompt"], rows,
                       align=["l", "l", "r", "l", "l"]), "",
        "Files: `smp.json` (base SMP), `variant_K.smp.json`, `variant_K.npz` (motion), "
        f"`variant_K_{result.location}.csv` (IMU), `prompts.txt`.", ""])
    payload = {"study": "case", "activity": result.activity, "source": result.source,
               "seed": result.seed, "location": result.location,
               "smp": result.smp.model_dump(mode="json"), "base_prompt": verbalize(result.smp),
               "variants": variants, "extraction": result.extraction,
               "frame_times_s": result.frame_times_s}
    report, results = write_report(out, md, payload)
    return {"figure": figure, "report": report, "results": results}
