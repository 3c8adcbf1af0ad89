"""Reading a campaign spec key by key: :class:`~rcsim.models.toml_reader.Reader` (types, key paths
in messages, unknown keys refused; shared with vehicle files) and the keys that name files
(:func:`file_key`, :func:`file_digest`).

Every mistake is an :class:`~rcsim.models.errors.InputError` naming the spec file, the key
path and the value.  Used by :mod:`~rcsim.analysis.engine.campaign.spec`, which knows what the keys
mean.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from rcsim.models.tables import PAPER_LOOKUP_TABLES, lookup_table_source
from rcsim.models.toml_reader import Reader


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
