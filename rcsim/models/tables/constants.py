"""Constants of the paper's control design, defined once for the whole code base.

Every other module (``spacecraft``, ``lookup``, ``analysis``) imports these from
:mod:`rcsim.models.tables`; none repeats the number.  Each value is one the paper states in its
*text* (Gambone, *Pattern Recognition Control Design*, section II), not a table value, or a
tolerance/range derived from such a value with the reason written beside it.
"""

from __future__ import annotations

AXES = ("roll", "pitch", "yaw")
#: Paper section II: "The spacecraft has 16 thrusters that can be used for rotational control."
N_JETS = 16
#: Paper section II: the 26 rate commands are "combinations of positive, negative and zero rate
#: commands in roll, pitch, and yaw" -- every pattern in {-,0,+}^3 except the all-zero one.
N_CASES = 3 ** len(AXES) - 1
#: The paper's control cycle, s.  Paper section II: "The control rate for the spacecraft model
#: is set to 40 milliseconds."  The paper's tables are whole cycles of it (the loaders' default
#: check).  A flight's cycle is its vehicle's flight-software profile's (``[control]
#: cycle_s``; ``paper.toml`` gives this value, a test checks they agree), never this constant.
PAPER_CYCLE_S = 0.040
#: Paper section II: "... for a 0.3 degrees per second total rate command for each run."
PAPER_TOTAL_RATE_DEG_S = 0.3

#: Relative tolerance on rate magnitudes.  The paper prints rates to 4 decimals (0.2121 for
#: 0.3/sqrt(2) = 0.212132, 0.1732 for 0.3/sqrt(3) = 0.173205).  A rounding error of at most
#: 5e-5 deg/s per component moves the norm of a 0.3 deg/s command by at most
#: 5e-5 * sqrt(3) / 0.3 = 2.9e-4 relative, so 1e-3 accepts every correctly rounded entry while
#: any real typo (a wrong digit in the first three places, or a 1-axis magnitude on a 2-axis
#: case, which is 29 % off) is far outside it.
RATE_RTOL = 1e-3
#: Absolute tolerance (s) for "firing time is a whole number of control cycles" and for "paired
#: jets fire equally long": far below one cycle, far above float error of a decimal like 0.28.
TIME_ATOL_S = 1e-9

# ------------------------------------------------------------------------------------------
# Physical ranges: a table can be well-formed and still be in the wrong units.
# ------------------------------------------------------------------------------------------
#: Range of the total rate command |(roll, pitch, yaw)| of one table case, deg/s.  The paper's
#: cases all command 0.3 deg/s (section II, Table 3); the range is a factor of ten either side
#: of it, so a table designed for a 10x slower or faster rate command still loads, while the
#: classic unit mistake -- rates written in rad/s under a deg/s header, 57.3x too small (0.3
#: deg/s = 0.00524 rad/s), or deg/s read as rad/s, 57.3x too large -- is refused: the lookup
#: controller scales firing times by rate error / table rate, so such a table commands firings
#: 57x too long (or short) and flies away while every cell is "valid".
RATE_TOTAL_MIN_DEG_S = PAPER_TOTAL_RATE_DEG_S / 10.0
RATE_TOTAL_MAX_DEG_S = PAPER_TOTAL_RATE_DEG_S * 10.0
#: Longest firing time a lookup-table cell may hold, s (125 control cycles).  The longest
#: entry of the paper's Tables 6/7 is 0.52 s (the 0.3 deg/s single-axis roll case); 5 s is
#: about ten times that, enough for a vehicle with ten times the inertia or a tenth of the
#: thrust, while a firing time in ms written under an s header (1000x) or a runaway value
#: (1e6 s) is refused.  It is also a control-horizon bound: the lookup controller computes a
#: new firing for an axis only when the remaining on time is below Table 4's on-time limit
#: (0.03 s), so while a jet is on its axis flies open loop; 5 s of that is already a fifth of
#: the paper's 5 deg maneuver at 0.2 deg/s (25 s), and a longer cell is an open-loop burn, not
#: a feedback pulse.
MAX_FIRING_TIME_S = 5.0

RATE_COLUMNS = tuple(f"{axis}_deg_s" for axis in AXES)
SIGN_COLUMNS = tuple(f"{axis}_sign" for axis in AXES)
JET_COLUMNS = tuple(f"jet_{j:02d}" for j in range(1, N_JETS + 1))
