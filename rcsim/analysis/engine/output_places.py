"""Where an output may go: never inside another command's output, never over its own input.

Outputs are not nested.  A directory a command wrote (it holds the marker of
:mod:`rcsim.analysis.engine.output_records`) or is writing in place (a campaign's, a loop's:
their state file) belongs to that command; an output inside it -- ``maneuver --out
CAMPAIGN/histories``, ``lookup generate --out LOOP/new.csv`` -- would be a file the owner did
not write, met later by its resume or its ``--overwrite``.  :func:`refuse_nested` refuses it,
naming the owner, ``--overwrite`` or not, with two exceptions a command makes on purpose:

* a command writing inside its own directory: the loop's stages (its campaigns, the driver
  analysis, the refined table), inside :func:`writing_inside`;
* ``rcsim campaign replay`` writing into the campaign's ``replays/`` folder (its default).

An output is not one of the command's inputs (:func:`refuse_own_inputs`): ``lookup refine
--table t6.csv --out t6.csv`` would replace the table it refines, and ``analyze D/x.csv --out D
--overwrite`` would delete what it reads.

Paths are compared with every symbolic link resolved.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
from pathlib import Path

from rcsim.analysis.engine.locks import real_path
from rcsim.analysis.engine.output_records import MARKER, MARKER_PREFIX
from rcsim.models.errors import InputError

#: Commands whose directories are written in place and resumed, and their state files.
RESUMABLE = {"campaign run": "manifest.json", "loop": "loop.json", "campaign rare": "rare.json"}
#: (owner, writer) -> the owner's sub-folder the writer may write into.
ALLOWED_INSIDE = {("campaign run", "campaign replay"): "replays"}

_inside_own: contextvars.ContextVar[tuple[str, ...]] = contextvars.ContextVar(
    "rcsim_inside_own", default=()
)


@contextlib.contextmanager
def writing_inside(directory: str | os.PathLike):
    """Inside the block, outputs directly owned by ``directory`` (the caller's own in-place
    directory, e.g. the loop's) are not refused as nested."""
    token = _inside_own.set(_inside_own.get() + (str(real_path(directory)),))
    try:
        yield
    finally:
        _inside_own.reset(token)


def marker_owner(path: str | os.PathLike) -> str | None:
    """The command named by directory ``path``'s marker: ``None`` without a marker, ``""``
    when it names none (an older rcsim's, unreadable), else e.g. ``"campaign run"``."""
    marker = Path(path) / MARKER
    if not marker.is_file():
        return None
    try:
        first = marker.read_text(errors="replace").splitlines()[:1]
    except OSError:
        return ""
    line = first[0].strip() if first else ""
    if not line.startswith(MARKER_PREFIX):
        return ""
    rest = line[len(MARKER_PREFIX) :]
    # Older markers read "written by rcsim; this directory is replaced by the next run".
    return rest.strip() if rest.startswith(" ") else ""


def resumable_owner(path: str | os.PathLike) -> str | None:
    """The resumable command (:data:`RESUMABLE`) whose directory ``path`` is, or None: by the
    marker first, then, whatever the marker says, by the command's own state file."""
    path = Path(path)
    owner = marker_owner(path)
    if owner in RESUMABLE:
        return owner
    for command, state_file in RESUMABLE.items():
        if (path / state_file).is_file():
            return command
    return None


def owning_output(path: str | os.PathLike) -> tuple[Path, str] | None:
    """The nearest directory above ``path`` (real path) that is an rcsim output, and the
    command that owns it (``""``: rcsim's, command unknown); None when there is none."""
    here = real_path(path).parent
    while True:
        owner = resumable_owner(here) or marker_owner(here)
        if owner is not None:
            return here, owner
        if here.parent == here:
            return None
        here = here.parent


def describe(command: str) -> str:
    """``a campaign directory`` and the like: what a directory owned by ``command`` is."""
    return {"campaign run": "a campaign directory", "loop": "a loop directory"}.get(
        command, "an output directory"
    )


def refuse_nested(
    path: str | os.PathLike, command: str | None, *, parameter: str = "out", shown=None
) -> None:
    """Refuse output ``path`` inside another command's output directory (module docstring).

    ``shown``: the path as the user wrote it, for the message (default ``path``).
    """
    found = owning_output(path)
    if found is None:
        return
    owner_dir, owner = found
    if str(owner_dir) in _inside_own.get():
        return
    sub = ALLOWED_INSIDE.get((owner, command or ""))
    if sub is not None:
        rel = real_path(path).relative_to(owner_dir).parts
        if len(rel) == 2 and rel[0] == sub:
            return
    shown = path if shown is None else shown
    by = f"written by `rcsim {owner}`" if owner else "written by an earlier rcsim command"
    raise InputError(
        f"{shown}: is inside {describe(owner)}, {owner_dir} ({by}); no output goes inside "
        "another (its owner's --overwrite or resume would meet files it did not write), "
        "--overwrite or not: choose a path outside it",
        parameter=parameter,
        value=str(shown),
    )


def refuse_own_inputs(outputs, inputs: dict, *, parameter: str = "out") -> None:
    """Refuse when an input lies at or under one of ``outputs`` (module docstring).

    Parameters
    ----------
    outputs : iterable of path
        What the command writes (files or directories); the first is named in the message.
    inputs : dict
        ``{what: path}``, e.g. ``{"--table": "t6.csv"}``; entries that name no existing path
        (a packaged table's name, None) are skipped.
    """
    outputs = [o for o in outputs if o is not None]
    if not outputs:
        return
    shown = outputs[0]
    for what, value in inputs.items():
        if value is None or not isinstance(value, (str, os.PathLike)):
            continue
        if not os.path.lexists(os.fspath(value)):
            continue
        source = real_path(value)
        for out in outputs:
            target = real_path(out)
            if source == target or target in source.parents:
                how = "is" if source == target else "holds"
                raise InputError(
                    f"{shown}: {how} this command's own input ({what} {value}); writing there "
                    "would replace what it reads, --overwrite or not: choose another path",
                    parameter=parameter,
                    value=str(shown),
                )
