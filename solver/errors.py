"""Errors a user can cause. The CLI turns each into one message and exit code 2.

They are plain exceptions so library users can catch them; the message is written
for a person: what is wrong, where, and how to fix it.
"""


class ProblemError(ValueError):
    """The problem is malformed, or cannot be solved as posed (too large, degenerate)."""


class TooLargeError(ProblemError):
    """The state-space estimate exceeds the memory budget; nothing was allocated.

    Its figures ride along as attributes, so a caller that speaks to its user in other
    terms (a city speaks of facades and sides, not of stage graphs and states) words its
    own message from them instead of reading the solver's text:

    - ``need_mb``: what solving would take, when it is known before starting;
    - ``budget_mb``: the memory budget it was measured against;
    - ``shares`` and ``resources``: for structure-wide intervals, the ways of sharing
      their totals between stages and the resources they are on;
    - ``k``: when what is too large is the number of solutions asked for.
    """

    def __init__(self, message: str, *, need_mb: float | None = None,
                 budget_mb: float | None = None, shares: int | None = None,
                 resources: tuple[str, ...] = (), k: int | None = None) -> None:
        super().__init__(message)
        self.need_mb = need_mb
        self.budget_mb = budget_mb
        self.shares = shares
        self.resources = resources
        self.k = k
