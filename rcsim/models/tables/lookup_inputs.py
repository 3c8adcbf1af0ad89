"""Pattern-recognition control-logic inputs (paper Table 4): :class:`LookupInputs` and its
loader."""

from __future__ import annotations

from dataclasses import dataclass

from rcsim.models.tables.schema import PathLike, long_table

# parameter -> (dimension, must be strictly positive)
_LOOKUP_PARAMETERS = {
    "maneuver_limit": ("angle", True),
    "maneuver_rate": ("angular_rate", True),
    "rate_error_limit": ("angular_rate", True),
    "on_time_limit": ("time", True),
    "hold_time": ("time", True),
}


@dataclass(frozen=True)
class LookupInputs:
    """Pattern-recognition control-logic inputs (paper Table 4), SI.

    Attributes
    ----------
    maneuver_limit_rad : float
        Total angle error above which the logic commands the maneuver rate, rad.
    maneuver_rate_rad_s : float
        Total maneuver rate, rad/s.
    rate_error_limit_rad_s : float
        Dead band: rate errors below this are treated as zero, rad/s.
    on_time_limit_s : float
        A new firing is computed only when the remaining on time of a jet and its opposing jet
        is below this, s.
    hold_time_s : float
        Settling time after a firing before another is commanded, s.
    """

    maneuver_limit_rad: float
    maneuver_rate_rad_s: float
    rate_error_limit_rad_s: float
    on_time_limit_s: float
    hold_time_s: float


def load_lookup_inputs(path: PathLike | None = None) -> LookupInputs:
    """Load the pattern-recognition logic inputs (paper Table 4).

    Parameters
    ----------
    path : str or os.PathLike, optional
        A ``parameter, unit, value`` CSV with parameters ``maneuver_limit`` (angle),
        ``maneuver_rate``, ``rate_error_limit`` (angular rate), ``on_time_limit``,
        ``hold_time`` (time).  Default: the packaged ``table4_lookup_inputs.csv``.

    Returns
    -------
    LookupInputs
        SI values (rad, rad/s, s).

    Raises
    ------
    rcsim.models.errors.InputError
        Missing/unknown column or parameter, bad or non-positive value, wrong unit dimension.

    Notes
    -----
    The paper's design rules -- maneuver rate at least three times the rate error limit, on
    time limit slightly below the 40 ms control cycle -- are recommendations, not checked here,
    so that stress studies can break them on purpose.
    """
    _, v = long_table(path, "table4_lookup_inputs.csv", "value", _LOOKUP_PARAMETERS)
    return LookupInputs(
        maneuver_limit_rad=v["maneuver_limit"],
        maneuver_rate_rad_s=v["maneuver_rate"],
        rate_error_limit_rad_s=v["rate_error_limit"],
        on_time_limit_s=v["on_time_limit"],
        hold_time_s=v["hold_time"],
    )
