"""SMPs extracted from source clips (`--source video:DIR`).

DIR holds one folder per activity (`DIR/<activity>/*.mp4`, the layout of a
source pool), or a pool manifest `DIR/manifest.json` written by
`vsmp-imu video pool` (only retained clips are used). Each clip's SMP comes
from the offline pose extractor (fused with the activity's library SMP when
the library knows it) and is cached next to the clip as `<clip>.smp.json`.
"""

from __future__ import annotations

import json
from pathlib import Path

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.io import write_text
from vsmp_imu.pipeline.sources import SmpDirSource
from vsmp_imu.smp import SMP, load_smp
from vsmp_imu.smp.library import ActivityLibrary

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm")


def pool_clips(folder: Path) -> list[tuple[str, Path]]:
    """(activity, clip) pairs from a manifest or from per-activity folders."""
    manifest = folder / "manifest.json"
    if manifest.exists():
        from vsmp_imu.extract.pool import retained_clips

        return retained_clips(json.loads(manifest.read_text()), folder)
    if not folder.is_dir():
        raise ConfigError("video source folder not found", file=folder, field="source")
    return [(sub.name, clip) for sub in sorted(p for p in folder.iterdir() if p.is_dir())
            for clip in sorted(sub.iterdir()) if clip.suffix.lower() in VIDEO_SUFFIXES]


class VideoSmpSource(SmpDirSource):
    """Per-clip SMPs from the pose extractor, assigned to dataset classes by activity."""

    name = "video"

    def __init__(self, folder: Path, library: ActivityLibrary) -> None:
        super().__init__(folder, library)

    def _smp(self, activity: str, clip: Path) -> SMP:
        cached = clip.with_name(clip.name + ".smp.json")
        if cached.exists():
            return load_smp(cached)
        from vsmp_imu.extract.pose import PoseExtractor

        base = None
        try:
            base = self.library.get(activity).smp
        except Exception:  # an activity the library does not know: pose evidence only
            base = None
        result = PoseExtractor(library=self.library).extract(
            clip, activity, base=base, mode="fuse" if base is not None else "replace")
        write_text(cached, result.smp.model_dump_json(indent=2) + "\n")
        return result.smp

    def smps(self, dataset: str, label_names):
        out: dict[str, list[tuple[str, SMP]]] = {}
        for activity, clip in pool_clips(self.folder):
            smp = self._smp(activity, clip)
            cls = self._class_of(smp, dataset, label_names) or self._class_of(
                smp.model_copy(update={"activity_label": activity}), dataset, label_names)
            if cls is not None:
                out.setdefault(cls, []).append((f"video:{clip.name}", smp))
        if not out:
            raise ValidationError("no clip matches a class of the dataset", file=self.folder,
                                  allowed=", ".join(label_names))
        return out
