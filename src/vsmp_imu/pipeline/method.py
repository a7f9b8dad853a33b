"""VSMP-IMU as a synthetic source of the HAR harness (`--methods vsmp`).

The harness calls `generate(context)` once per fold with only the training
side of that fold; the whole of Algorithm 1 runs inside, fold-isolated.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.fold import FoldGenerator, FoldOutput
from vsmp_imu.pipeline.sources import LibrarySmpSource, SmpDirSource, parse_source
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary


def make_smp_source(source: str, library: ActivityLibrary):
    """The SMP source named by `--source` (library | smp:DIR | video:DIR)."""
    kind, folder = parse_source(source)
    if kind == "library":
        return LibrarySmpSource(library)
    if kind == "smp":
        return SmpDirSource(folder, library)
    from vsmp_imu.pipeline.video_source import VideoSmpSource

    return VideoSmpSource(folder, library)


def fold_key(context: FoldContext) -> str:
    """A name for the fold that keeps protocol, label budget and seed apart."""
    budget = "full" if context.label_budget is None else f"{context.label_budget:g}pct"
    return f"{context.protocol}-{budget}-s{context.seed}-fold{context.fold}"


@dataclass
class VsmpMethod:
    """Generates VSMP-IMU windows for each fold of an evaluation (`spec`: with the variant's
    switches already applied, see `vsmp_imu.methods`)."""

    spec: GenerationSpec = field(default_factory=GenerationSpec)
    name: str = "vsmp"
    last_output_: FoldOutput | None = None

    def generate(self, context: FoldContext) -> Windows:
        spec = self.spec
        library = ActivityLibrary.load([Path(d) for d in spec.library_dirs])
        info = context.dataset
        sources = make_smp_source(spec.source, library).smps(info.name, info.label_names)
        cache = Path(spec.cache_dir) if spec.cache_dir else None
        generator = FoldGenerator(spec, spec.make_executor(show_progress=False), cache, library=library)
        out = generator.generate(info, context.train, sources, context.budget_vector(), context.seed,
                                 fold_key(context))
        self.last_output_ = out
        return out.windows
