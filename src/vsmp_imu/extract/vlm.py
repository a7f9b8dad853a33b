"""Video -> SMP with a vision-language model (paper, "Video-Grounded SMP Extraction with a
Pretrained VLM" and appendix "VLM-Based SMP Extraction").

A clip is sampled to N_f frames (`frames.FrameSampler`), sent with the
appendix prompt and schema as base64 JPEG data URLs in one chat-completions
user message, `n_queries` (5) times. Each raw answer is repaired
(`smp.repair.parse_response`), the parsed answers are aggregated
(`smp.aggregate.aggregate`, fewer than 3 valid -> the clip is discarded) and
the aggregate is refined (`smp.refine.Refiner`). The result keeps all three
stages (raw responses, aggregated SMP, refined SMP) and the failure counts of
the paper's extraction audit.

The clip's label is the class the data is for: when it names a library
activity and the responses' majority names another one, the clip is discarded
(the responses must also name one activity by a strict majority, see
`aggregate`).
"""

from __future__ import annotations

import base64
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.extract.client import Completion, VLMClient
from vsmp_imu.extract.frames import FrameSampler, SampledFrames, encode_jpeg
from vsmp_imu.extract.prompt import (
    LABEL_HINT_TEMPLATE,
    TIMING_TEMPLATE,
    prompt_sha256,
    smp_prompt,
)
from vsmp_imu.smp.aggregate import aggregate, library_activity
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import Refiner
from vsmp_imu.smp.repair import RepairResult, parse_response
from vsmp_imu.smp.schema import SMP, smp_json_schema

N_QUERIES = 5  # appendix: five queries per clip
MIN_VALID = 3  # appendix: fewer than three valid outputs -> discard
MAX_QUERIES = 20  # paid requests per clip at most: four times the paper's
JPEG_QUALITY = 90
Progress = Callable[[int, int], None]


def image_data_url(frame: Any, quality: int = JPEG_QUALITY) -> str:
    """A `data:image/jpeg;base64,...` URL of an RGB frame."""
    return "data:image/jpeg;base64," + base64.b64encode(encode_jpeg(frame, quality)).decode("ascii")


def text_parts(sampled: SampledFrames, label_hint: str | None, include_timing: bool) -> list[str]:
    """The text parts of the user message: prompt+schema, label hint, timing."""
    parts = [smp_prompt()]
    if label_hint:
        parts.append(LABEL_HINT_TEMPLATE.format(label=label_hint))
    if include_timing:
        n = sampled.n_frames
        step = (float(sampled.times_s[-1] - sampled.times_s[0]) / (n - 1)) if n > 1 else 0.0
        parts.append(TIMING_TEMPLATE.format(duration_s=sampled.duration_s, n=n, step_s=step))
    return parts


def build_messages(sampled: SampledFrames, texts: list[str],
                   quality: int = JPEG_QUALITY) -> list[dict[str, Any]]:
    """One user message: the text parts, then every frame as an image_url content part."""
    content: list[dict[str, Any]] = [{"type": "text", "text": t} for t in texts]
    content += [{"type": "image_url", "image_url": {"url": image_data_url(f, quality)}}
                for f in sampled.frames]
    return [{"role": "user", "content": content}]


def smp_response_format() -> dict[str, Any]:
    """The JSON-schema response_format for structured output."""
    return {"type": "json_schema",
            "json_schema": {"name": "semantic_motion_program", "schema": smp_json_schema(),
                            "strict": False}}


def unusable_smp(content: str) -> str | None:
    """None when the answer repairs to an SMP (so it may be cached); else why not."""
    parsed = parse_response(content)
    return None if parsed.smp is not None else (parsed.report.reason or "no SMP in the answer")


@dataclass
class FailureCounts:
    """The paper's extraction-audit counts for one clip (appendix "SMP audit metrics").

    Response level (out of `queries`): request_failures, malformed_json,
    missing_mandatory_field, invalid_value, rejected, valid, repaired.
    Clip level (0 or 1): five_response_disagreement, schema_repair,
    semantic_correction, discarded.
    """

    queries: int = 0
    cached: int = 0
    retries: int = 0
    request_failures: int = 0
    format_fallbacks: int = 0
    malformed_json: int = 0
    missing_mandatory_field: int = 0
    invalid_value: int = 0
    rejected: int = 0
    valid: int = 0
    repaired: int = 0
    five_response_disagreement: int = 0
    schema_repair: int = 0
    semantic_correction: int = 0
    corrections: int = 0
    discarded: int = 0

    def to_dict(self) -> dict[str, int]:
        return asdict(self)


@dataclass
class ExtractionResult:
    """Everything one clip's extraction produced (JSON-serializable via `to_dict`)."""

    extractor: str
    label: str | None
    smp: SMP | None
    clip: dict[str, Any]
    discarded: bool = False
    reason: str | None = None
    endpoint: dict[str, Any] = field(default_factory=dict)
    prompt_sha256: str | None = None
    queries: list[dict[str, Any]] = field(default_factory=list)
    repairs: list[dict[str, Any]] = field(default_factory=list)
    aggregation: dict[str, Any] | None = None
    aggregated_smp: SMP | None = None
    refinement: dict[str, Any] | None = None
    counts: FailureCounts = field(default_factory=FailureCounts)

    @property
    def raw_responses(self) -> list[str | None]:
        return [q.get("content") for q in self.queries]

    def to_dict(self) -> dict[str, Any]:
        return {
            "extractor": self.extractor, "label": self.label,
            "smp": None if self.smp is None else self.smp.model_dump(mode="json"),
            "discarded": self.discarded, "reason": self.reason, "clip": self.clip,
            "endpoint": self.endpoint, "prompt_sha256": self.prompt_sha256,
            "queries": self.queries, "repairs": self.repairs, "aggregation": self.aggregation,
            "aggregated_smp": (None if self.aggregated_smp is None
                               else self.aggregated_smp.model_dump(mode="json")),
            "refinement": self.refinement, "counts": self.counts.to_dict(),
        }


@dataclass(eq=False, repr=False)
class VLMExtractor:
    """Five VLM queries per clip -> repair -> aggregate -> refine.

    client: the endpoint (`VLMClient`).
    n_queries: queries per clip (5 in the paper); min_valid: discard below (3).
    sampler: frame sampling (default: 16 frames, 512 px).
    library: the activity library for refinement (None: built-in).
    refine: run the four consistency checks.
    label_hint: send the clip's label with the prompt (when a label is given).
    include_timing: tell the model the clip duration and frame spacing.
    jpeg_quality: quality of the frame JPEGs.
    """

    client: VLMClient
    n_queries: int = N_QUERIES
    min_valid: int = MIN_VALID
    sampler: FrameSampler | None = None
    library: ActivityLibrary | None = None
    refine: bool = True
    label_hint: bool = True
    include_timing: bool = True
    jpeg_quality: int = JPEG_QUALITY

    def check(self) -> None:
        """Range checks, before any request: min_valid <= n_queries <= MAX_QUERIES."""
        if not self.min_valid >= 1:
            raise ConfigError(f"{self.min_valid} is out of range", field="min_valid", allowed="an integer >= 1")
        if not self.min_valid <= self.n_queries <= MAX_QUERIES:
            raise ConfigError(
                f"{self.n_queries} queries is out of range", field="n_queries",
                allowed=f"{self.min_valid}..{MAX_QUERIES} (fewer than min_valid = {self.min_valid} "
                        "would always discard the clip)")

    def _library(self) -> ActivityLibrary:
        if self.library is None:
            self.library = ActivityLibrary.load()
        return self.library

    def _other_activity(self, label: str | None, smp: SMP) -> str | None:
        """Why the SMP is not of the clip's class: both labels name library activities
        (`ActivityLibrary.identify`), and different ones; None otherwise."""
        if label is None:
            return None
        wanted, got = self._library().identify(label), self._library().identify(smp.activity_label)
        if wanted is None or got is None or wanted.name == got.name:
            return None
        return (f"the responses name '{smp.activity_label}' (activity {got.name}), not the clip's "
                f"label '{label}' (activity {wanted.name})")

    def _request(self, sampled: SampledFrames, label: str | None) -> tuple[list[dict[str, Any]], list[str]]:
        texts = text_parts(sampled, label if self.label_hint else None, self.include_timing)
        return build_messages(sampled, texts, self.jpeg_quality), texts

    def _key_fields(self, sampled: SampledFrames, texts: list[str], index: int) -> dict[str, Any]:
        settings = (self.sampler or FrameSampler()).settings()
        return {"task": "smp", "clip_sha256": sampled.clip_hash,
                "frames": {"indices": [int(i) for i in sampled.indices],
                           "size_px": settings["size_px"], "jpeg_quality": self.jpeg_quality},
                "prompt_sha256": prompt_sha256(*texts),
                "params": {"temperature": self.client.temperature,
                           "max_tokens": self.client.max_tokens},
                "query_index": index}

    def preview(self, video: str | Path, label: str | None = None) -> dict[str, Any]:
        """The exact request (dry run): nothing is sent."""
        self.check()
        sampled = (self.sampler or FrameSampler()).sample(video)
        messages, texts = self._request(sampled, label)
        return {"requests_per_clip": self.n_queries, "clip": sampled.to_dict(),
                "prompt_sha256": prompt_sha256(*texts),
                "request": self.client.preview(messages, smp_response_format())}

    def extract(self, video: str | Path, label: str | None = None,
                progress: Progress | None = None) -> ExtractionResult:
        """Extract the SMP of one clip (`label`: the clip's dataset label, optional)."""
        self.check()
        sampled = (self.sampler or FrameSampler()).sample(video)
        messages, texts = self._request(sampled, label)
        completions: list[Completion] = []
        for k in range(self.n_queries):
            completions.append(self.client.complete(messages, self._key_fields(sampled, texts, k),
                                                    smp_response_format(), accept=unusable_smp))
            if progress is not None:
                progress(k + 1, self.n_queries)
        return self._finish(sampled, label, texts, completions)

    def _finish(self, sampled: SampledFrames, label: str | None, texts: list[str],
                completions: list[Completion]) -> ExtractionResult:
        parsed: list[RepairResult | None] = [parse_response(c.content) if c.ok else None
                                             for c in completions]
        counts = _count(completions, parsed)
        result = ExtractionResult(
            "vlm", label, None, sampled.to_dict(),
            endpoint={"base_url": self.client.base_url, "model": self.client.model},
            prompt_sha256=prompt_sha256(*texts),
            queries=[{"index": k, **c.to_dict()} for k, c in enumerate(completions)],
            repairs=[{"index": k, "request_failed": p is None,
                      **(p.report.to_dict() if p is not None else {})}
                     for k, p in enumerate(parsed)],
            counts=counts)
        agg = aggregate([p.smp if p is not None else None for p in parsed], min_valid=self.min_valid,
                        activity_of=library_activity(self._library()))
        result.aggregation = {k: v for k, v in agg.to_dict().items() if k != "smp"}
        counts.five_response_disagreement = int(agg.any_disagreement)
        if agg.smp is None:
            failed = f"; {counts.request_failures} request(s) failed" if counts.request_failures else ""
            return _discard(result, f"{agg.reason}{failed}")
        result.aggregated_smp = agg.smp
        other = self._other_activity(label, agg.smp)
        if other is not None:
            return _discard(result, other)
        final = agg.smp
        if self.refine:
            refined = Refiner(self.library).refine(agg.smp)
            result.refinement = {"entry": refined.entry,
                                 "corrections": [c.to_dict() for c in refined.corrections]}
            counts.corrections = len(refined.corrections)
            counts.semantic_correction = int(refined.corrected)
            final = refined.smp
        result.smp = final
        return result


def _discard(result: ExtractionResult, reason: str) -> ExtractionResult:
    result.discarded, result.reason = True, reason
    result.counts.discarded = 1
    return result


def _count(completions: list[Completion], parsed: list[RepairResult | None]) -> FailureCounts:
    c = FailureCounts(queries=len(completions))
    for comp, p in zip(completions, parsed, strict=True):
        c.cached += int(comp.cached)
        c.retries += comp.retries
        c.format_fallbacks += int(comp.format_fallback)
        if p is None:
            c.request_failures += 1
            continue
        r = p.report
        c.malformed_json += int(r.malformed_json)
        c.missing_mandatory_field += int(bool(r.missing_mandatory))
        c.invalid_value += int(bool(r.invalid_values))
        c.rejected += int(r.rejected)
        c.valid += int(p.smp is not None)
        c.repaired += int(r.repaired)
    c.schema_repair = int(c.repaired > 0)
    return c
