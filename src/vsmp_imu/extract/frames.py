"""Clip-level frame sampling (paper appendix "Video Preprocessing and Frame Sampling").

A clip is decoded with OpenCV, `N_f` frames are taken uniformly over the
whole clip (first and last frame included), each is resized to 512 x 512
with its aspect ratio kept and black bars added (letterbox). A clip with
fewer than `N_f` frames repeats frames (nearest-neighbour temporal padding).

Containers can lie about their frame count and frame rate. The reader walks
the whole stream once with `grab()` (cheap: nothing is converted), keeps the
frames it needs, and compares the decoded count with the header; when they
differ, the indices are recomputed from the decoded count and the needed
frames are read in a second pass. Frame times come from the decoder's
timestamps when the header's frame rate is missing or absurd.
"""

from __future__ import annotations

import math
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, DependencyError, InputFileError
from vsmp_imu.io import file_sha256

FRAME_SIZE_PX = 512  # appendix table: 512 x 512 for every dataset
MAX_FPS = 1000.0  # a header frame rate above this (or <= 0) is treated as missing
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v", ".mpg", ".mpeg", ".wmv")


@dataclass(frozen=True)
class FramePreset:
    """One row of the appendix table: frames per clip and the clip-duration rule."""

    name: str
    n_frames: int
    min_duration_s: float
    max_duration_s: float
    description: str


# Appendix "Video Preprocessing and Frame Sampling", Table (dataset-specific parameters).
PRESETS: dict[str, FramePreset] = {
    p.name: p
    for p in (
        FramePreset("mm_fit", 24, 2.0, 12.0, "MM-Fit"),
        FramePreset("utd_mhad", 16, 1.0, 8.0, "UTD-MHAD"),
        FramePreset("mmact", 32, 2.0, 17.0, "MMAct"),
        FramePreset("pamap2", 32, 3.0, 15.0, "PAMAP2 source videos"),
        FramePreset("had_aw", 32, 3.0, 12.0, "HAD-AW source videos"),
    )
}
DEFAULT_N_FRAMES = 16
# Bounds of the sampled frames, checked before a clip is decoded: the presets send 8..32 frames
# of 512 px; 2048 px is four times the paper's side; all frames together stay under 1 GiB.
MAX_N_FRAMES = 256
MAX_FRAME_PX = 2048
MAX_FRAME_BYTES = 2**30


def preset(name: str) -> FramePreset:
    """The preset called `name` (case-insensitive; '-' and '_' alike)."""
    key = name.strip().lower().replace("-", "_")
    if key not in PRESETS:
        raise ConfigError(f"unknown frame-sampling preset '{name}'", field="preset",
                          allowed=", ".join(PRESETS))
    return PRESETS[key]


def require_cv2() -> Any:
    """Import OpenCV, or say how to install it."""
    try:
        import cv2
    except ImportError as exc:  # pragma: no cover - the dev environment has it
        raise DependencyError("reading video needs OpenCV (the `video` extra); install it with "
                              "`pip install -e .[video]`") from exc
    return cv2


@dataclass
class VideoInfo:
    """What the stream really holds (decoded count) and what its header said."""

    path: str
    sha256: str
    n_frames: int
    fps: float
    duration_s: float
    width: int
    height: int
    header_n_frames: int
    header_fps: float
    frame_count_source: str  # "header" (confirmed by decoding) or "decoded"
    fps_source: str  # "header" or "timestamps"

    def to_dict(self) -> dict[str, Any]:
        return {"path": self.path, "sha256": self.sha256, "n_frames": self.n_frames,
                "fps": self.fps, "duration_s": self.duration_s, "width": self.width,
                "height": self.height, "header_n_frames": self.header_n_frames,
                "header_fps": self.header_fps, "frame_count_source": self.frame_count_source,
                "fps_source": self.fps_source}


@dataclass
class SampledFrames:
    """The sampled frames of one clip and where they came from."""

    frames: np.ndarray  # (N, S, S, 3) uint8 RGB, letterboxed
    indices: np.ndarray  # (N,) source frame index of each sampled frame
    times_s: np.ndarray  # (N,) source time of each sampled frame
    info: VideoInfo
    size_px: int
    preset: str | None = None
    warnings: list[str] = field(default_factory=list)

    @property
    def n_frames(self) -> int:
        return int(self.frames.shape[0])

    @property
    def clip_hash(self) -> str:
        return self.info.sha256

    @property
    def fps(self) -> float:
        return self.info.fps

    @property
    def duration_s(self) -> float:
        return self.info.duration_s

    @property
    def original_size(self) -> tuple[int, int]:
        """(width, height) of the source frames."""
        return self.info.width, self.info.height

    def to_dict(self) -> dict[str, Any]:
        """Everything but the pixels (JSON-serializable)."""
        return {"clip": self.info.to_dict(), "n_sampled": self.n_frames, "size_px": self.size_px,
                "preset": self.preset, "indices": [int(i) for i in self.indices],
                "times_s": [round(float(t), 6) for t in self.times_s],
                "warnings": list(self.warnings)}


def _file_kind(mode: int) -> str | None:
    """What a non-regular file is (None for a regular file)."""
    kinds = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
             (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"),
             (stat.S_ISBLK, "a block device"))
    return next((name for test, name in kinds if test(mode)), None)


def check_video_path(path: Path) -> None:
    """A video must be a regular file: OpenCV waits for ever opening a FIFO no one writes to,
    deaf to Ctrl-C and SIGTERM."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise InputFileError("video file not found", file=path) from None
    except OSError as exc:
        raise InputFileError(f"cannot look at the video ({exc.strerror})", file=path) from None
    kind = _file_kind(mode)
    if kind is not None:
        raise InputFileError(f"expected a video file, found {kind}", file=path)


def _open(path: Path) -> Any:
    cv2 = require_cv2()
    check_video_path(path)
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        cap.release()
        raise InputFileError("cannot open the video (not a video file, corrupt, or a codec "
                             "OpenCV's FFmpeg cannot decode)", file=path)
    return cap


def _header(cap: Any) -> tuple[int, float, int, int]:
    cv2 = require_cv2()
    count = cap.get(cv2.CAP_PROP_FRAME_COUNT)
    fps = cap.get(cv2.CAP_PROP_FPS)
    width = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH) or 0)
    height = int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT) or 0)
    count_i = int(count) if math.isfinite(count) and count > 0 else 0
    fps_f = float(fps) if math.isfinite(fps) and 0 < fps <= MAX_FPS else 0.0
    return count_i, fps_f, width, height


def header_duration_s(video: str | Path) -> float | None:
    """How long the clip's header says it lasts (None when it gives no frame count or rate);
    nothing is decoded."""
    cap = _open(Path(video))
    try:
        count, fps, _, _ = _header(cap)
    finally:
        cap.release()
    return count / fps if count and fps else None


def uniform_indices(n_total: int, n_frames: int) -> np.ndarray:
    """`n_frames` indices spread uniformly over 0..n_total-1 (repeats when n_total < n_frames)."""
    if n_total < 1 or n_frames < 1:
        raise ConfigError("need at least one frame to sample", field="n_frames")
    return np.round(np.linspace(0, n_total - 1, n_frames)).astype(np.int64)


def _walk(cap: Any, wanted: set[int]) -> tuple[dict[int, np.ndarray], list[float], tuple[int, int]]:
    """Grab every frame; retrieve (BGR) the wanted ones; return them with all timestamps."""
    cv2 = require_cv2()
    kept: dict[int, np.ndarray] = {}
    stamps: list[float] = []
    size = (0, 0)
    index = 0
    while cap.grab():
        stamps.append(float(cap.get(cv2.CAP_PROP_POS_MSEC)) / 1000.0)
        if index in wanted:
            ok, frame = cap.retrieve()
            if ok and frame is not None:
                kept[index] = frame
                size = (frame.shape[1], frame.shape[0])
        index += 1
    return kept, stamps, size


def _fps_from_stamps(stamps: list[float]) -> float:
    diffs = np.diff(np.asarray(stamps, dtype=float))
    diffs = diffs[diffs > 0]
    if diffs.size == 0:
        return 0.0
    return float(1.0 / np.median(diffs))


def letterbox(frame: np.ndarray, size_px: int = FRAME_SIZE_PX) -> np.ndarray:
    """Resize to fit a size_px square with the aspect ratio kept; pad with black, centred."""
    cv2 = require_cv2()
    h, w = frame.shape[:2]
    scale = size_px / max(h, w)
    new_w, new_h = max(1, round(w * scale)), max(1, round(h * scale))
    interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
    resized = cv2.resize(frame, (new_w, new_h), interpolation=interp)
    out = np.zeros((size_px, size_px, 3), dtype=np.uint8)
    top, left = (size_px - new_h) // 2, (size_px - new_w) // 2
    out[top:top + new_h, left:left + new_w] = resized
    return out


@dataclass(eq=False, repr=False)
class FrameSampler:
    """Uniform temporal sampling of a clip to `n_frames` letterboxed RGB frames.

    n_frames: frames per clip (default 16, or the preset's N_f).
    preset: a row of the appendix table (`mm_fit`, `utd_mhad`, `mmact`,
        `pamap2`, `had_aw`): sets n_frames (unless given) and the duration rule.
    size_px: output side length (512 in the paper).
    min_duration_s / max_duration_s: the clip-duration rule; a clip outside
        it is still sampled and a warning is added to the result.
    """

    n_frames: int | None = None
    preset: str | None = None
    size_px: int = FRAME_SIZE_PX
    min_duration_s: float | None = None
    max_duration_s: float | None = None

    def settings(self) -> dict[str, Any]:
        """The resolved sampling settings (used in cache keys)."""
        row = preset(self.preset) if self.preset else None
        n = self.n_frames if self.n_frames is not None else (row.n_frames if row else DEFAULT_N_FRAMES)
        if not 1 <= n <= MAX_N_FRAMES:
            raise ConfigError(f"{n} frames cannot be sampled", field="n_frames", allowed=f"1..{MAX_N_FRAMES}")
        if not 16 <= self.size_px <= MAX_FRAME_PX:
            raise ConfigError(f"a frame side of {self.size_px} px is out of range", field="size_px",
                              allowed=f"16..{MAX_FRAME_PX} px")
        if n * self.size_px**2 * 3 > MAX_FRAME_BYTES:
            raise ConfigError(f"{n} frames of {self.size_px} px would take {n * self.size_px**2 * 3 / 2**30:.1f} GiB",
                              field="size_px", allowed="fewer or smaller frames: n x side^2 x 3 bytes <= 1 GiB")
        lo = self.min_duration_s if self.min_duration_s is not None else (row.min_duration_s if row else None)
        hi = self.max_duration_s if self.max_duration_s is not None else (row.max_duration_s if row else None)
        return {"n_frames": int(n), "size_px": int(self.size_px), "preset": row.name if row else None,
                "min_duration_s": lo, "max_duration_s": hi}

    def sample(self, video: str | Path) -> SampledFrames:
        """Decode `video` and return its sampled frames (InputFileError if unreadable)."""
        cv2 = require_cv2()
        cfg = self.settings()
        path = Path(video)
        cap = _open(path)
        try:
            header_count, header_fps, width, height = _header(cap)
            wanted = uniform_indices(header_count, cfg["n_frames"]) if header_count else np.zeros(0, int)
            kept, stamps, size = _walk(cap, set(wanted.tolist()))
        finally:
            cap.release()
        n_decoded = len(stamps)
        if n_decoded == 0:
            raise InputFileError("no frame could be decoded (empty or corrupt video)", file=path)
        warnings: list[str] = []
        count_source = "header"
        if n_decoded != header_count:
            count_source = "decoded"
            warnings.append(f"the container says {header_count} frames but {n_decoded} were "
                            "decoded; sampled over the decoded frames")
            wanted = uniform_indices(n_decoded, cfg["n_frames"])
            missing = set(wanted.tolist()) - set(kept)
            if missing:
                cap = _open(path)
                try:
                    more, _, size2 = _walk(cap, missing)
                finally:
                    cap.release()
                kept.update(more)
                size = size if size != (0, 0) else size2
        lost = sorted(set(wanted.tolist()) - set(kept))
        if lost:
            raise InputFileError(f"{len(lost)} frame(s) could not be decoded (first: {lost[0]})",
                                 file=path)
        fps, fps_source = header_fps, "header"
        if fps <= 0:
            fps, fps_source = _fps_from_stamps(stamps), "timestamps"
            if fps <= 0:
                raise InputFileError("the video gives no usable frame rate (header and "
                                     "timestamps both missing)", file=path)
            warnings.append(f"no valid frame rate in the header; {fps:.3f} fps from timestamps")
        width, height = size if size != (0, 0) else (width, height)
        duration_s = n_decoded / fps
        info = VideoInfo(str(path), file_sha256(path), n_decoded, fps, duration_s, width, height,
                         header_count, header_fps, count_source, fps_source)
        lo, hi = cfg["min_duration_s"], cfg["max_duration_s"]
        name = cfg["preset"] or "the duration rule"
        if lo is not None and duration_s < lo:
            warnings.append(f"clip lasts {duration_s:.2f} s, shorter than {lo:g} s ({name})")
        if hi is not None and duration_s > hi:
            warnings.append(f"clip lasts {duration_s:.2f} s, longer than {hi:g} s ({name}); "
                            "sampled over the whole clip")
        if n_decoded < cfg["n_frames"]:
            warnings.append(f"clip has {n_decoded} frames, fewer than {cfg['n_frames']}; frames "
                            "repeated (nearest-neighbour temporal padding)")
        frames = np.stack([letterbox(cv2.cvtColor(kept[int(i)], cv2.COLOR_BGR2RGB), cfg["size_px"])
                           for i in wanted])
        return SampledFrames(frames, wanted, wanted / fps, info, cfg["size_px"], cfg["preset"],
                             warnings)


def probe(video: str | Path) -> VideoInfo:
    """Decode the whole clip once (no pixels kept) and report what it holds."""
    path = Path(video)
    cap = _open(path)
    try:
        header_count, header_fps, width, height = _header(cap)
        kept, stamps, size = _walk(cap, {0})
    finally:
        cap.release()
    if not stamps:
        raise InputFileError("no frame could be decoded (empty or corrupt video)", file=path)
    fps, fps_source = (header_fps, "header") if header_fps > 0 else (_fps_from_stamps(stamps), "timestamps")
    if fps <= 0:
        raise InputFileError("the video gives no usable frame rate", file=path)
    width, height = size if size != (0, 0) else (width, height)
    n = len(stamps)
    return VideoInfo(str(path), file_sha256(path), n, fps, n / fps, width, height, header_count,
                     header_fps, "header" if n == header_count else "decoded", fps_source)


def contact_sheet(frames: np.ndarray, columns: int | None = None, tile_px: int = 192,
                  labels: list[str] | None = None) -> np.ndarray:
    """One RGB image with the frames in a grid (row-major), optional text labels."""
    cv2 = require_cv2()
    n = len(frames)
    if n == 0:
        raise ConfigError("no frames to put on a contact sheet", field="frames")
    cols = columns or int(math.ceil(math.sqrt(n)))
    rows = int(math.ceil(n / cols))
    sheet = np.full((rows * tile_px, cols * tile_px, 3), 32, dtype=np.uint8)
    for k, frame in enumerate(frames):
        tile = cv2.resize(frame, (tile_px, tile_px), interpolation=cv2.INTER_AREA)
        if labels is not None:
            cv2.putText(tile, labels[k], (4, tile_px - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        (255, 255, 0), 1, cv2.LINE_AA)
        r, c = divmod(k, cols)
        sheet[r * tile_px:(r + 1) * tile_px, c * tile_px:(c + 1) * tile_px] = tile
    return sheet


def encode_png(image: np.ndarray) -> bytes:
    """PNG bytes of an RGB uint8 image."""
    cv2 = require_cv2()
    ok, buf = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    if not ok:  # pragma: no cover - OpenCV always encodes uint8 RGB
        raise InputFileError("PNG encoding failed")
    return buf.tobytes()


def encode_jpeg(image: np.ndarray, quality: int = 90) -> bytes:
    """JPEG bytes of an RGB uint8 image."""
    cv2 = require_cv2()
    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(image, cv2.COLOR_RGB2BGR),
                           [int(cv2.IMWRITE_JPEG_QUALITY), int(quality)])
    if not ok:  # pragma: no cover
        raise InputFileError("JPEG encoding failed")
    return buf.tobytes()


FRAME_NAME = re.compile(r"frame_(?:\d{3}|[1-9]\d{3,})\.png")  # the names write_frames gives frames


def write_frames(sampled: SampledFrames, out_dir: str | Path, columns: int | None = None) -> list[Path]:
    """Write `frame_000.png` ..., `contact_sheet.png` and `frames.json` into `out_dir`.

    Frame PNGs of an earlier run there that this one does not write are removed, so the folder
    holds exactly the frames `frames.json` lists; other files are left alone.
    """
    from vsmp_imu.io import write_bytes, write_json

    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputFileError("output must be a folder", file=out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for k, frame in enumerate(sampled.frames):
        written.append(write_bytes(out / f"frame_{k:03d}.png", encode_png(frame)))
    _remove_stale_frames(out, {p.name for p in written})
    labels = [f"#{int(i)} {t:.2f}s" for i, t in zip(sampled.indices, sampled.times_s, strict=True)]
    sheet = contact_sheet(sampled.frames, columns=columns, labels=labels)
    written.append(write_bytes(out / "contact_sheet.png", encode_png(sheet)))
    written.append(write_json(out / "frames.json", sampled.to_dict()))
    return written


def _remove_stale_frames(out: Path, kept: set[str]) -> None:
    for path in out.iterdir():
        if FRAME_NAME.fullmatch(path.name) and path.name not in kept and path.is_file():
            path.unlink()
