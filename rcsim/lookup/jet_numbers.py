"""A jets-off list checked: the jets a table or recipe is made without, numbered 1..n.

One check for jet tables (:func:`rcsim.lookup.jet_sets.check_jets_off`, the paper's 16 jets) and
channel tables (:func:`rcsim.lookup.channels.check_channel_jets_off`, the vehicle file's count).
Imports nothing of rcsim but its error type.
"""

from __future__ import annotations

from rcsim.models.errors import InputError


def jet_numbers(jets_off, n_jets: int) -> tuple:
    """``jets_off`` as a sorted tuple of distinct whole jet numbers 1..``n_jets``; InputError
    otherwise (the one check of a jets-off list, for jet and channel tables alike)."""
    try:
        jets = [int(j) for j in jets_off]
    except (TypeError, ValueError):
        raise InputError(
            f"must be jet numbers 1..{n_jets}, got {jets_off!r}", parameter="jets_off", value=None
        ) from None
    bad = [j for j in jets if not 1 <= j <= n_jets]
    if bad:
        raise InputError(
            f"no jet {bad[0]}; jets are 1..{n_jets}", parameter="jets_off", value=list(jets_off)
        )
    dup = sorted({j for j in jets if jets.count(j) > 1})
    if dup:
        raise InputError(f"jet {dup[0]} appears twice", parameter="jets_off", value=list(jets_off))
    if any(int(j) != j for j in jets_off):
        raise InputError(
            f"must be whole jet numbers, got {list(jets_off)}",
            parameter="jets_off",
            value=list(jets_off),
        )
    return tuple(sorted(jets))
