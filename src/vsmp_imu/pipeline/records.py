"""The records the fold stages pass on: a sample's provenance and one record per window.

`Provenance` is what a synthetic sample remembers of how it was made (source,
SMP variant, prompt, backend and seed, the motion, the motion verdict, per
location theta, eta* and gamma, and how many real training windows of its class
the fold's grounding and filter had: 0 for a class with no evidence, whose
sample is grounded on what the other classes teach). `WindowRecord` is one generated window (or a
failed sample) with its filter verdicts (`FilterVerdict`, the filters' own
`Verdict`) and kept/selected flags. Both turn into plain dicts (`as_dict`)
with exactly the keys the Parquet output and the per-sample cache store.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from vsmp_imu.filtering.verdict import Verdict

FilterVerdict = Verdict


@dataclass(frozen=True)
class MotionSummary:
    """The motion of a sample: its size, body height, active span and backend controls."""

    fps: float
    n_frames: int
    duration_s: float
    body_height_m: float
    active_span_s: list[float]  # [start, end] seconds between which the body moves
    controls: Any = None  # the backend's controls (JSON-ready), if it reports them

    def as_dict(self) -> dict[str, Any]:
        return {"fps": self.fps, "n_frames": self.n_frames, "duration_s": self.duration_s,
                "body_height_m": self.body_height_m, "active_span_s": self.active_span_s,
                "controls": self.controls}


@dataclass(frozen=True)
class LocationProvenance:
    """One sensor location of a sample: theta, the mounting perturbation, eta* and gamma."""

    start_s: float  # motion time of the first IMU sample
    theta: dict[str, Any]
    mounting_perturbation_xyzw: list[float]
    nominal_mounting_xyzw: list[float]
    eta: dict[str, Any] | None  # the CEM's result (None: no simulation-in-the-loop)
    gamma: dict[str, Any]  # the target convention

    def as_dict(self) -> dict[str, Any]:
        return {"start_s": self.start_s, "theta": self.theta,
                "mounting_perturbation_xyzw": self.mounting_perturbation_xyzw,
                "nominal_mounting_xyzw": self.nominal_mounting_xyzw, "eta": self.eta, "gamma": self.gamma}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LocationProvenance:
        return cls(d["start_s"], d["theta"], d["mounting_perturbation_xyzw"], d["nominal_mounting_xyzw"],
                   d["eta"], d["gamma"])


@dataclass(frozen=True)
class Provenance:
    """How a sample was made; a failed sample keeps only its source and label (`motion` None)."""

    source: str
    label: str
    variant: int | None = None
    smp_id: str | None = None
    prompt: str | None = None
    backend: str | None = None
    seed: int | None = None
    motion: MotionSummary | None = None
    motion_verdict: Verdict | None = None
    locations: dict[str, LocationProvenance] = field(default_factory=dict)
    class_windows: int | None = None  # real training windows of the class in the fold (None: not known)

    @property
    def failed(self) -> bool:
        return self.motion is None

    def active_span_s(self) -> list[float] | None:
        return None if self.motion is None else self.motion.active_span_s

    def start_s(self) -> float:
        """Motion time of the first IMU sample (of the first location)."""
        return next(iter(self.locations.values())).start_s if self.locations else 0.0

    @property
    def class_evidence(self) -> bool | None:
        """Whether the fold had real windows of the sample's class (None: not known)."""
        return None if self.class_windows is None else self.class_windows > 0

    def as_dict(self) -> dict[str, Any]:
        known = {} if self.class_windows is None else {"class_windows": self.class_windows}
        if self.failed:
            return {"source": self.source, "label": self.label, **known}
        return {"source": self.source, "label": self.label, "variant": self.variant, "smp_id": self.smp_id,
                "prompt": self.prompt, "backend": self.backend, "seed": self.seed,
                "motion": self.motion.as_dict(), "motion_verdict": self.motion_verdict.as_dict(),
                "locations": {name: loc.as_dict() for name, loc in self.locations.items()}, **known}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Provenance:
        if "motion" not in d:
            return cls(d["source"], d["label"], class_windows=d.get("class_windows"))
        return cls(d["source"], d["label"], d["variant"], d["smp_id"], d["prompt"], d["backend"], d["seed"],
                   MotionSummary(**d["motion"]), Verdict(**d["motion_verdict"]),
                   {name: LocationProvenance.from_dict(loc) for name, loc in d["locations"].items()},
                   d.get("class_windows"))


@dataclass
class WindowRecord:
    """One generated window (`window` its index in the sample), or a failed sample (`window`
    None, `error` its message); the filter stage fills `verdicts` and `kept`, selection
    `selected`."""

    sample: str
    label: str
    window: int | None
    provenance: Provenance
    start_s: float | None = None
    locations: list[str] = field(default_factory=list)
    error: str | None = None
    kept: bool = True
    selected: bool = False
    verdicts: list[FilterVerdict] = field(default_factory=list)
    intensity: float | None = None  # the intensity spread's factor (grounding.intensity; None: not spread)

    @property
    def windowed(self) -> bool:
        return self.window is not None

    def first_failure(self) -> FilterVerdict | None:
        return next((v for v in self.verdicts if not v.passed), None)
