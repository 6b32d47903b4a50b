"""The one exception type for user mistakes.

The CLI turns an `FbilError` into a single line on stderr and exit code 2, so the
message must name the problem and the fix on its own.
"""


class FbilError(ValueError):
    """A user-facing error (bad input, unknown name, corrupt file)."""
