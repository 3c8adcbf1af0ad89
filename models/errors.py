"""The one exception type for user mistakes.

Every layer raises :class:`InputError` for bad input a user can fix (a table with a missing
column, a negative duration, an unknown key in a campaign spec).  The CLI turns it into a
one-line message and exit code 2; anything else is a bug and keeps its traceback.
"""


class InputError(ValueError):
    """Bad user input; the message names the file, field and value."""
