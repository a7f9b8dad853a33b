"""A filter verdict: pass or fail, which filter decided, and why."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field


@dataclass(frozen=True)
class Verdict:
    passed: bool
    filter: str
    reason: str = ""
    values: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return asdict(self)


def first_failure(verdicts: list[Verdict]) -> Verdict | None:
    """The first failing verdict, or None when all passed."""
    return next((v for v in verdicts if not v.passed), None)
