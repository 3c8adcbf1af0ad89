"""Reading a campaign spec key by key: :class:`Reader` (types, key paths in messages, unknown
keys refused) and the keys that name files (:func:`file_key`, :func:`file_digest`).

Every mistake is an :class:`~models.errors.InputError` naming the spec file, the key
path and the value.  Used by :mod:`~analysis.engine.campaign.spec`, which knows what the keys mean.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

from models.errors import InputError
from models.tables import PAPER_LOOKUP_TABLES, lookup_table_source


class Reader:
    """Pops keys from a table, checking types; remembers the key path for messages."""

    def __init__(self, table: dict, path: str, source: str):
        if not isinstance(table, dict):
            raise InputError(f"{source}: {path or 'spec'}: expected a table, got {table!r}")
        self.table, self.path, self.source = dict(table), path, source

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, problem: str, value=None) -> InputError:
        got = "" if value is None else f" (got {value!r})"
        return InputError(f"{self.source}: {self.key(name)}: {problem}{got}")

    def has(self, name: str) -> bool:
        return name in self.table

    def raw(self, name: str, default=None):
        return self.table.pop(name, default)

    def integer(self, name: str, default, *, minimum: int, maximum: int | None = None) -> int:
        value = self.table.pop(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"must be an integer >= {minimum}", value)
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be an integer in {minimum}..{maximum}", value)
        return int(value)

    def number(self, name: str, default, *, minimum: float | None = None, strict=False) -> float:
        value = self.table.pop(name, default)
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise self.error(name, "must be a finite number", value)
        if minimum is not None and (value <= minimum if strict else value < minimum):
            raise self.error(name, f"must be {'>' if strict else '>='} {minimum}", value)
        return float(value)

    def choice(self, name: str, default, choices) -> str:
        value = self.table.pop(name, default)
        if value is None:
            raise self.error(name, f"is required; one of {', '.join(choices)}")
        if value not in choices:
            raise self.error(name, f"must be one of {', '.join(choices)}", value)
        return value

    def vector3(self, name: str, default) -> list[float]:
        value = self.table.pop(name, default)
        if value is None:
            raise self.error(name, "is required: a list of 3 numbers [roll, pitch, yaw]")
        if (
            not isinstance(value, list)
            or len(value) != 3
            or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value
            )
        ):
            raise self.error(name, "must be a list of 3 finite numbers", value)
        return [float(v) for v in value]

    def table_(self, name: str) -> Reader:
        return Reader(self.table.pop(name, {}), self.key(name), self.source)

    def done(self) -> None:
        """Reject whatever was not read: a typo must not silently fall back to a default."""
        for name in self.table:
            raise InputError(f"{self.source}: unknown key '{self.key(name)}'")


def file_key(r: Reader, name: str, base_dir: Path | None, names=()) -> str | None:
    """A ``"default"``-or-path key, made absolute (the file must exist), or one of ``names``
    (packaged files, kept as the name)."""
    value = r.raw(name, "default")
    if not isinstance(value, str) or not value:
        listed = "".join(f', "{n}"' for n in names)
        raise r.error(name, f'must be "default"{listed} or a file path', value)
    if value == "default":
        return None
    if value in names:
        # Relative paths are relative to the spec; never silently prefer the name or a file.
        local = Path(value) if base_dir is None else base_dir / value
        if local.exists():
            raise r.error(
                name,
                f"ambiguous: both the packaged paper table {value!r} and the "
                f'file {local}; write "./{value}" for the file',
                value,
            )
        return value
    path = Path(value).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    if not path.is_file():
        raise r.error(name, "file not found", str(path))
    return str(path.resolve())


def file_digest(path: str | None) -> str | None:
    """SHA-256 of a file, or of the packaged paper table a name stands for."""
    if path is None:
        return None
    if path in PAPER_LOOKUP_TABLES:
        return hashlib.sha256(lookup_table_source(path).read_bytes()).hexdigest()
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
