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
            if parts and (str(item).startswith(("literal[", "function-")) or item in ("float", "int", "str", "bool")):
                continue
            parts.append(("." if parts else "") + str(item))
    return "".join(parts)


def _allowed(error: dict[str, Any]) -> str | None:
    ctx = error.get("ctx") or {}
    if "expected" in ctx:
        return str(ctx["expected"])
    if error.get("type") in ("greater_than_equal", "less_than_equal", "greater_than", "less_than"):
        return ", ".join(f"{k} {v}" for k, v in ctx.items())
    return None


def validation_error(exc: pydantic.ValidationError, file: str | Path | None = None) -> ValidationError:
    """The first problem as a ValidationError; the others listed in the message."""
    errors = exc.errors()
    first = errors[0]
    field = _loc(first["loc"]) or None
    msg = first["msg"]
    if "input" in first and not isinstance(first["input"], dict | list):
        msg += f" (got {first['input']!r})"
    others = sorted({_loc(e["loc"]) for e in errors[1:]} - {field})
    if others:
        msg += f"; {len(others)} more field(s) invalid: {', '.join(others[:5])}"
    return ValidationError(msg, file=file, field=field, allowed=_allowed(first))


def validate_model(model: type[M], data: Any, file: str | Path | None = None) -> M:
    """Validate `data` into `model`, raising a project ValidationError."""
    try:
        return model.model_validate(data)
    except pydantic.ValidationError as exc:
        raise validation_error(exc, file) from exc
