"""VSMP-IMU as a synthetic source of the HAR harness (`--methods vsmp`).

The harness calls `generate(context)` once per fold with only the training
side of that fold; the whole of Algorithm 1 runs inside, fold-isolated.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vsmp_imu.executor import LocalExecutor
from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.fold import FoldGenerator, FoldOutput, GenerationConfig
from vsmp_imu.pipeline.sources import LibrarySmpSource, SmpDirSource, parse_source
from vsmp_imu.pipeline.variants import ABLATIONS
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
    """Generates VSMP-IMU windows for each fold of an evaluation."""

    config: GenerationConfig = field(default_factory=GenerationConfig)
    source: str = "library"
    executor: Any = None
    cache_dir: Path | None = None
    name: str = "vsmp"
    last_output_: FoldOutput | None = None

    def generate(self, context: FoldContext) -> Windows:
        library = ActivityLibrary.load([Path(d) for d in self.config.library_dirs])
        info = context.dataset
        sources = make_smp_source(self.source, library).smps(info.name, info.label_names)
        executor = self.executor or LocalExecutor(1, show_progress=False)
        generator = FoldGenerator(self.config, executor, self.cache_dir, library=library)
        out = generator.generate(info, context.train, sources, context.budget_vector(), context.seed,
                                 fold_key(context))
        self.last_output_ = out
        return out.windows


def make_vsmp_method(variant: str = "vsmp", source: str = "library", k: int = 4, backend: str = "procedural",
                     per_class_rank: bool = False, library_dirs: tuple[str, ...] = (), workers: int = 1,
                     executor: str = "local", address: str | None = None,
                     cache_dir: str | None = None, refill: int = 0) -> VsmpMethod:
    """A VsmpMethod for one ablation variant, from plain (command-line) parameters."""
    from vsmp_imu.executor import make_executor

    _, switches = ABLATIONS[variant]
    settings: dict[str, Any] = {"k": k, "backend": backend, "per_class_rank": per_class_rank,
                                "library_dirs": tuple(library_dirs), "refill": refill}
    config = GenerationConfig(**{**settings, **switches})
    return VsmpMethod(config=config, source=source, name=variant,
                      executor=make_executor(executor, workers, address, show_progress=False),
                      cache_dir=Path(cache_dir) if cache_dir else None)

