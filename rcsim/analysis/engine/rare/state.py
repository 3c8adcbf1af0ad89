"""The state of a rare-event estimation after each finished level, and its file.

A subset simulation is a sequence of levels; everything the next level needs is the finished
level's samples, the records of the levels so far, the proposal scale and the failure samples
found.  The random numbers of level ``j`` come from their own stream
(:func:`level_generator`), so no generator state is kept: a killed estimation resumed from its
file draws exactly what the uninterrupted one would have drawn, and gives the same answer bit
for bit (``tests/analysis/engine/rare/test_state.py``).

The file is one ``.npz`` (numpy arrays, no pickle) holding the arrays and a JSON document of the
rest; it is written to a temporary file beside it and renamed over it, so a kill leaves either
the previous level's state or the new one, never half of one.  A state records the fingerprint
of the problem it belongs to (dimension, settings, seed, and a caller's label of the limit
state): resuming with anything else is refused, naming what differs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np

from rcsim.models.errors import InputError

#: Version of the file layout (a different one is refused, not guessed at).
STATE_VERSION = 1


def level_generator(root: np.random.SeedSequence, level: int) -> np.random.Generator:
    """The generator of level ``level``: child ``(level,)`` of the estimation's root sequence,
    ``SeedSequence(root.entropy, spawn_key=root.spawn_key + (level,))`` (what ``root.spawn``
    would give, without its counter)."""
    child = np.random.SeedSequence(root.entropy, spawn_key=tuple(root.spawn_key) + (int(level),))
    return np.random.default_rng(child)


def fingerprint(problem: dict) -> str:
    """SHA-256 of a problem's JSON (sorted keys): what a state file must match to resume."""
    text = json.dumps(problem, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


@dataclass(frozen=True)
class LevelRecord:
    """One finished level of a subset simulation.

    Attributes
    ----------
    level : int
        0 for the plain Monte Carlo level.
    threshold : float
        The margin below which the next region lies (``b_{j+1}``), or 0 at a final level.
    probability : float
        ``p_j``: the fraction of the level's samples in the next region (the failure region
        at a final level).
    gamma : float
        The chains' correlation factor of that fraction (:func:`..intervals.chain_gamma`).
    cov2 : float
        ``delta_j^2`` of ``p_j``.
    n_samples, n_failures : int
        The level's samples and those with a margin below 0.
    acceptance : float or None
        Mean acceptance of the level's Markov-chain moves (None at level 0, which has none).
    scale : float
        The proposal scale ``lambda`` at the end of the level.
    n_evaluations : int
        Limit-state evaluations so far (all levels up to this one).
    final : bool
        The level reached the failure region with enough samples: the estimate ends here.
    """

    level: int
    threshold: float
    probability: float
    gamma: float
    cov2: float
    n_samples: int
    n_failures: int
    acceptance: float | None
    scale: float
    n_evaluations: int
    final: bool


@dataclass
class SubsetState:
    """Where a subset simulation stands after its last finished level.

    Attributes
    ----------
    problem : dict
        The settings it runs with (JSON): dimension, level sizes, seed, the caller's label.
    levels : list of LevelRecord
    u : ndarray, (N, d)
        The last level's samples in standard-normal space, chain by chain state (row
        ``l * n_c + c`` is state ``l`` of chain ``c``; level 0: ``N`` independent draws).
    margins : ndarray, (N,)
        Their margins (non-finite ones already replaced by ``-inf``).
    ids : ndarray of int64, (N,)
        Their evaluation ids (the order in which points were first evaluated).
    scale : float
        The proposal scale the next level starts from.
    n_evaluations : int
    n_nonfinite : int
        Evaluations whose margin was not finite (counted as failures).
    fail_u, fail_margins, fail_ids : ndarray
        Every evaluated point with a margin below 0, once each: (k, d), (k,), (k,).
    """

    problem: dict
    levels: list[LevelRecord]
    u: np.ndarray
    margins: np.ndarray
    ids: np.ndarray
    scale: float
    n_evaluations: int
    n_nonfinite: int = 0
    fail_u: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))
    fail_margins: np.ndarray = field(default_factory=lambda: np.empty(0))
    fail_ids: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))

    def add_failures(self, u: np.ndarray, margins: np.ndarray, ids: np.ndarray) -> None:
        """Keep the points of a freshly evaluated batch whose margin is below 0."""
        bad = margins < 0.0
        if not bad.any():
            return
        if self.fail_u.size == 0:
            self.fail_u = np.empty((0, u.shape[1]))
        self.fail_u = np.concatenate([self.fail_u, u[bad]])
        self.fail_margins = np.concatenate([self.fail_margins, margins[bad]])
        self.fail_ids = np.concatenate([self.fail_ids, ids[bad].astype(np.int64)])

    def save(self, path: str | os.PathLike) -> None:
        """Write the state to ``path`` atomically (module docstring)."""
        path = Path(path)
        meta = {
            "version": STATE_VERSION,
            "problem": self.problem,
            "fingerprint": fingerprint(self.problem),
            "levels": [dataclasses.asdict(r) for r in self.levels],
            "scale": self.scale,
            "n_evaluations": self.n_evaluations,
            "n_nonfinite": self.n_nonfinite,
        }
        arrays = {
            "u": self.u,
            "margins": self.margins,
            "ids": self.ids,
            "fail_u": self.fail_u,
            "fail_margins": self.fail_margins,
            "fail_ids": self.fail_ids,
            # JSON keeps floats exactly (repr round-trips); inf and NaN as JSON's extensions.
            "meta": np.array(json.dumps(meta)),
        }
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as f:
                # Not savez's allow_pickle keyword: numpy 1.26 (the lowest supported) would
                # store it as an array; load() refuses pickles.
                np.savez(f, **cast("dict[str, Any]", arrays))
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    @classmethod
    def load(cls, path: str | os.PathLike, problem: dict) -> SubsetState:
        """Read a state written by :meth:`save` for ``problem``.

        Raises
        ------
        InputError
            The file is not such a state, or belongs to another problem (naming the first
            setting that differs).
        """
        try:
            with np.load(Path(path), allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files}
            meta = json.loads(str(arrays.pop("meta")))
        except (OSError, ValueError, KeyError) as exc:
            raise InputError(f"{path}: not a rare-event state file ({exc})") from None
        if meta.get("version") != STATE_VERSION:
            raise InputError(
                f"{path}: state file version {meta.get('version')!r}, expected {STATE_VERSION}"
            )
        if meta["fingerprint"] != fingerprint(problem):
            old = meta["problem"]
            differ = sorted(k for k in set(old) | set(problem) if old.get(k) != problem.get(k))
            key = differ[0] if differ else "fingerprint"
            raise InputError(
                f"{path}: the state belongs to another estimation ({key}: "
                f"{old.get(key)!r} there, {problem.get(key)!r} now); use a new state file"
            )
        return cls(
            problem=meta["problem"],
            levels=[LevelRecord(**r) for r in meta["levels"]],
            u=arrays["u"],
            margins=arrays["margins"],
            ids=arrays["ids"],
            scale=float(meta["scale"]),
            n_evaluations=int(meta["n_evaluations"]),
            n_nonfinite=int(meta["n_nonfinite"]),
            fail_u=arrays["fail_u"],
            fail_margins=arrays["fail_margins"],
            fail_ids=arrays["fail_ids"],
        )
