"""The one exception type for user mistakes.

Every layer raises :class:`InputError` for bad input a user can fix (a table with a missing
column, a negative duration, an unknown key in a campaign spec).  The CLI turns it into a
one-line message and exit code 2; anything else is a bug and keeps its traceback.

Library code names its *own* parameters, never a command-line flag: a function with a
``runs`` parameter raises ``InputError("must be >= 2, got 1", parameter="runs", value=1)``,
which reads "runs must be >= 2, got 1" from Python and "--runs must be >= 2, got 1" from the
``rcsim`` CLI, which knows which flag fills which parameter.  A field of an input *file*
(a campaign spec key, a table column) is not a parameter: its message names the file, the
field and the value itself, and leaves ``parameter`` unset.
"""

from __future__ import annotations

from typing import Any


class InputError(ValueError):
    """Bad user input; the message names the file, field and value.

    Parameters
    ----------
    message : str
        What is wrong and the value, e.g. ``"must be an integer >= 2, got 1"``.  With
        ``parameter`` it is the text *after* the parameter's name.
    parameter : str, optional
        Name of the library function's parameter that holds the bad value (``"runs"``,
        ``"out"``); front ends show it under their own name for it (``--runs``).
    value : object, optional
        The offending value, for programs that handle the error (None: not given).

    Examples
    --------
    >>> str(InputError("must be >= 2, got 1", parameter="runs", value=1))
    'runs must be >= 2, got 1'
    >>> InputError("must be >= 2, got 1", parameter="runs").render("--runs")
    '--runs must be >= 2, got 1'
    """

    def __init__(self, message: str, *, parameter: str | None = None, value: Any = None) -> None:
        self.message = message
        self.parameter = parameter
        self.value = value
        super().__init__(self.render())

    def render(self, name: str | None = None) -> str:
        """The message with the parameter shown as ``name`` (default: its own name)."""
        name = name or self.parameter
        return f"{name} {self.message}" if name else self.message

    def __reduce__(self):
        # Keyword-only fields survive pickling (Dask workers raise these across processes).
        return (_rebuild, (self.message, self.parameter, self.value))


def _rebuild(message, parameter, value):
    return InputError(message, parameter=parameter, value=value)
