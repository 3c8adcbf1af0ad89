"""Checks and helpers shared by the driver estimators (inputs, labels, random state)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rcsim.models.errors import InputError


def check_xy(X, y, strata=None):
    """Validate a design matrix and binary labels.

    Parameters
    ----------
    X : DataFrame or array-like, (n, p)
        Numeric, finite inputs.
    y : array-like of bool or {0, 1}, (n,)
        True for a failed run.
    strata : array-like, (n,), optional
        Group labels (rate cases) to permute within.

    Returns
    -------
    X : ndarray float (n, p), y : ndarray bool (n,), strata : ndarray (n,), names : list of str
    """
    names = (
        [str(c) for c in X.columns]
        if isinstance(X, pd.DataFrame)
        else [f"x{j}" for j in range(np.shape(X)[1])]
    )
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[1] == 0:
        raise InputError(f"X must be a 2-D array with at least one column, got shape {X.shape}")
    if not np.all(np.isfinite(X)):
        bad = names[int(np.flatnonzero(~np.isfinite(X).all(axis=0))[0])]
        raise InputError(f"X column {bad!r} holds NaN or infinite values")
    y = np.asarray(y)
    if y.shape != (X.shape[0],):
        raise InputError(f"y must have shape ({X.shape[0]},), got {y.shape}")
    if y.dtype != bool:
        if not np.isin(y, (0, 1)).all():
            raise InputError("y must be binary (bool or 0/1)")
        y = y.astype(bool)
    if y.all() or not y.any():
        raise InputError("y needs both failed and successful runs")
    strata = np.zeros(X.shape[0], int) if strata is None else np.asarray(strata)
    if strata.shape != y.shape:
        raise InputError(f"strata must have shape {y.shape}, got {strata.shape}")
    return X, y, strata, names


def as_rng(random_state) -> np.random.Generator:
    """A Generator from an int seed or a Generator (no global state)."""
    if isinstance(random_state, np.random.Generator):
        return random_state
    return np.random.default_rng(random_state)


def minority_of(y: np.ndarray) -> np.ndarray:
    """The smaller class as a mask (TV is symmetric, and the smaller class is cheaper to count)."""
    return y if y.sum() <= y.size - y.sum() else ~y
