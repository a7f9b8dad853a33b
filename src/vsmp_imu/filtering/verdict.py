"""A filter verdict: pass or fail, which filter decided, and why."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Verdict:
    passed: bool
    filter: str
    reason: str = ""
    values: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
        # by hand: dataclasses.asdict deep-copies recursively and was a tenth of a fold's filter time
        return {"passed": self.passed, "filter": self.filter, "reason": self.reason, "values": dict(self.values)}


def first_failure(verdicts: list[Verdict]) -> Verdict | None:
    """The first failing verdict, or None when all passed."""
    return next((v for v in verdicts if not v.passed), None)
