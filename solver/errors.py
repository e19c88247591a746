"""Errors a user can cause. The CLI turns each into one message and exit code 2.

They are plain exceptions so library users can catch them; the message is written
for a person: what is wrong, where, and how to fix it.
"""


class ProblemError(ValueError):
    """The problem is malformed, or cannot be solved as posed (too large, degenerate)."""


class TooLargeError(ProblemError):
    """The state-space estimate exceeds the memory budget; nothing was allocated."""
