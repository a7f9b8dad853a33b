"""Turn pydantic validation errors into project errors that name file and field."""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import pydantic

from vsmp_imu.errors import ValidationError

M = TypeVar("M", bound=pydantic.BaseModel)


def _loc(loc: tuple[Any, ...]) -> str:
    parts: list[str] = []
    for item in loc:
        if isinstance(item, int):
            parts.append(f"[{item}]")
        else:
            # pydantic adds union-branch tags such as "literal['a','b']" or "float"
            if parts and (str(item).startswith(("literal[", "function-", "constrained-")) or item in ("float", "int", "str", "bool")):
                continue
            parts.append(("." if parts else "") + str(item))
    return "".join(parts)


BOUNDS = {"ge": ">=", "gt": ">", "le": "<=", "lt": "<"}
NUMBER_KINDS = {"int": "an integer", "float": "a number", "bool": "true or false"}


def _allowed(error: dict[str, Any]) -> str | None:
    """What one error (one branch of a union) allows, in words."""
    ctx = error.get("ctx") or {}
    if "expected" in ctx:
        return str(ctx["expected"])
    if error.get("type") == "string_too_long":
        return f"text of at most {ctx['max_length']} characters"
    tags = [str(item).removeprefix("constrained-") for item in error["loc"] if isinstance(item, str)]
    kind = next((NUMBER_KINDS[t] for t in reversed(tags) if t in NUMBER_KINDS), None)
    bounds = " and ".join(f"{BOUNDS[k]} {v}" for k, v in ctx.items() if k in BOUNDS)
    if error.get("type") == "finite_number":
        bounds = "finite"
    text = " ".join(part for part in (kind, bounds) if part)
    return text or None


def _first_branch(errors: list[dict[str, Any]], field: str | None) -> tuple[dict[str, Any], str | None]:
    """The error to report for `field` and what all its union branches allow together: a
    number given to a 'word or number' field reports the number's range, not the words."""
    branches = [e for e in errors if (_loc(e["loc"]) or None) == field]
    numeric = [e for e in branches if e.get("type") != "literal_error"]
    given = branches[0].get("input")
    first = numeric[0] if numeric and not isinstance(given, str) else branches[0]
    allowed = [a for a in dict.fromkeys(_allowed(e) for e in branches) if a]
    return first, " or ".join(allowed) or None


SHOWN_INPUT_CHARS = 60  # of a refused value in a message; a 10 MB label is not printed whole


def _shortened(value: Any) -> str:
    """The repr of a refused value, cut to SHOWN_INPUT_CHARS with its length said."""
    text = repr(value)
    if len(text) <= SHOWN_INPUT_CHARS:
        return text
    size = f", {len(value)} characters" if isinstance(value, str) else ""
    return f"{text[:SHOWN_INPUT_CHARS]}...{size}"


def validation_error(exc: pydantic.ValidationError, file: str | Path | None = None) -> ValidationError:
    """The first problem as a ValidationError; the others listed in the message."""
    errors = exc.errors()
    field = _loc(errors[0]["loc"]) or None
    first, allowed = _first_branch(errors, field)
    msg = first["msg"].removeprefix("Value error, ")  # a model's own check speaks for itself
    if "input" in first and not isinstance(first["input"], dict | list):
        msg += f" (got {_shortened(first['input'])})"
    others = sorted({_loc(e["loc"]) for e in errors[1:]} - {field})
    if others:
        msg += f"; {len(others)} more field(s) invalid: {', '.join(others[:5])}"
    return ValidationError(msg, file=file, field=field, allowed=allowed)


def validate_model(model: type[M], data: Any, file: str | Path | None = None) -> M:
    """Validate `data` into `model`, raising a project ValidationError."""
    try:
        return model.model_validate(data)
    except pydantic.ValidationError as exc:
        raise validation_error(exc, file) from exc
