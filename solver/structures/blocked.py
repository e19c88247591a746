"""Where a structure with no solution is blocked: the hand-off from the stage providers
(:mod:`.stage_graphs`, :mod:`.decompose`) through :class:`.solve.StructureResult` to the
callers that tell a user which side of which building cannot be filled."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Blocked:
    """The stage a failed structure's reason names, as data (so a caller locates and
    words it without reading the text): its index, the reason's text for it, and the
    per-constraint details of its one-stage diagnosis
    (:func:`citysynth.solver.diagnose.diagnose`)."""

    stage: int
    text: str                        # "stage <i> between <a> and <b>: <why>"
    details: list[dict]
