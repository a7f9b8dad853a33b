"""One exception family for the whole project.

Every user mistake raises a `VsmpError` (or a child). The CLI turns it into a
one-paragraph message and exit code 2. A message names the file, the field and
what is allowed, so a user can fix the input without reading code.
"""

from __future__ import annotations

import copy
from pathlib import Path


class VsmpError(Exception):
    """Base class of every error this project raises on purpose."""

    def __init__(
        self,
        message: str,
        *,
        file: str | Path | None = None,
        field: str | None = None,
        allowed: str | None = None,
    ) -> None:
        self.message = message
        self.file = str(file) if file is not None else None
        self.field = field
        self.allowed = allowed
        super().__init__(self.render())

    def render(self) -> str:
        """The one-paragraph message shown to a user."""
        parts = []
        if self.file:
            parts.append(f"{self.file}:")
        if self.field:
            parts.append(f"field '{self.field}':")
        parts.append(self.message.rstrip("."))
        text = " ".join(parts) + "."
        if self.allowed:
            text += f" Allowed: {self.allowed}."
        return text

    def in_file(self, file: str | Path) -> VsmpError:
        """The same error naming `file` (the user's input it came from)."""
        return self._named(file=str(file))

    def in_field(self, field: str) -> VsmpError:
        """The same error naming `field` (the option the user typed, say)."""
        return self._named(field=field)

    def _named(self, **names: str) -> VsmpError:
        named = copy.copy(self)
        for key, value in names.items():
            setattr(named, key, value)
        named.args = (named.render(),)
        return named


class ValidationError(VsmpError):
    """Input that does not match its schema or its allowed values."""


class InputFileError(VsmpError):
    """A file that is missing, unreadable or in the wrong format."""


class ConfigError(VsmpError):
    """A bad option, configuration value or combination of them."""


class DependencyError(VsmpError):
    """An optional component (an extra, weights, a GPU) is not available."""


class ExtractionError(VsmpError):
    """SMP extraction failed (e.g. fewer than 3 valid responses)."""


class ServiceError(VsmpError):
    """A remote service (e.g. the VLM endpoint) failed after retries."""


class SampleError(VsmpError):
    """One synthetic sample cannot be made from its inputs (a prompt that names no activity,
    a motion with non-finite joints, an SMP variant with a field out of range). The pipeline
    records the sample as failed, with this message, and goes on; any other exception in a
    sample is a bug and fails the run."""


def some_of(items, shown: int = 5) -> str:
    """'a, b, c, d, e and 3 more': the first `shown` of `items` (as text) for a message, so that
    a list of thousands (a motion's joints, a folder's files) stays one paragraph."""
    items = [str(item) for item in items]
    return ", ".join(items[:shown]) + (f" and {len(items) - shown} more" if len(items) > shown else "")
