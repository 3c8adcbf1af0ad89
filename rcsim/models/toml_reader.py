"""Reading a TOML input file key by key: :class:`Reader` (types, key paths in messages,
unknown keys refused).

Every mistake is an :class:`~rcsim.models.errors.InputError` naming the file, the key path and the
value.  Campaign specs (:mod:`rcsim.analysis.engine.campaign.spec`) and vehicle files
(:mod:`rcsim.spacecraft.vehicle`) read their keys with it, so both follow one error rule.
"""

from __future__ import annotations

import math

from rcsim.models.errors import InputError


class Reader:
    """Pops keys from a table, checking types; remembers the key path for messages, and the
    keys it was asked for (the keys the table takes, listed when an unknown one is refused).

    ``note``: said after the key path in every message, e.g. ``" (fwd_yaw_plus)"`` naming the
    ``[[jet]]`` block ``jet[9]`` is."""

    def __init__(self, table: dict, path: str, source: str, note: str = ""):
        if not isinstance(table, dict):
            raise InputError(f"{source}: {path or 'spec'}: expected a table, got {table!r}")
        self.table, self.path, self.source, self.note = dict(table), path, source, note
        self.asked: dict[str, None] = {}  # the keys read or asked about, in order
        # Keys accepted but not offered in a message: what a manifest records for a resume
        # (checksums end in _sha256 and are never listed either).
        self.unlisted: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, problem: str, value=None) -> InputError:
        got = "" if value is None else f" (got {value!r})"
        return InputError(f"{self.source}: {self.key(name)}{self.note}: {problem}{got}")

    def _pop(self, name: str, default):
        self.asked[name] = None
        return self.table.pop(name, default)

    def takes(self, *names: str) -> None:
        """Say that the table takes ``names`` although they are read elsewhere (listed when an
        unknown key is refused)."""
        self.asked.update(dict.fromkeys(names))

    def has(self, name: str) -> bool:
        self.asked[name] = None
        return name in self.table

    def raw(self, name: str, default=None):
        return self._pop(name, default)

    def integer(self, name: str, default, *, minimum: int, maximum: int | None = None) -> int:
        value = self._pop(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise self.error(name, f"must be an integer >= {minimum}", value)
        if maximum is not None and value > maximum:
            raise self.error(name, f"must be an integer in {minimum}..{maximum}", value)
        return int(value)

    def number(self, name: str, default, *, minimum: float | None = None, strict=False) -> float:
        value = self._pop(name, default)
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
        value = self._pop(name, default)
        if value is None:
            raise self.error(name, f"is required; one of {', '.join(choices)}")
        if value not in choices:
            raise self.error(name, f"must be one of {', '.join(choices)}", value)
        return value

    def vector3(self, name: str, default) -> list[float]:
        value = self._pop(name, default)
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
        return Reader(self._pop(name, {}), self.key(name), self.source)

    def done(self) -> None:
        """Reject whatever was not read: a typo must not silently fall back to a default.  The
        message names the closest key this table takes and lists them all."""
        import difflib

        for name in self.table:
            known = [
                k
                for k in self.asked
                if k != name and k not in self.unlisted and not k.endswith("_sha256")
            ]
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.6)
            hint = f"; did you mean '{self.key(close[0])}'?" if close else ""
            where = f"[{self.path}]" if self.path else "the top level"
            takes = f" ({where} takes {', '.join(known)})" if known else ""
            raise InputError(
                f"{self.source}: unknown key '{self.key(name)}'{self.note}{hint}{takes}"
            )

    def vector(self, name: str, n: int, default=None, *, required: bool = True):
        """A list of ``n`` finite numbers as a tuple of floats; None when absent and not
        ``required``."""
        value = self._pop(name, default)
        if value is None:
            if required:
                raise self.error(name, f"is required: a list of {n} numbers")
            return None
        if (
            not isinstance(value, list)
            or len(value) != n
            or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                for v in value
            )
        ):
            raise self.error(name, f"must be a list of {n} finite numbers", value)
        return tuple(float(v) for v in value)
