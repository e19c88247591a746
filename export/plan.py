"""What export places from: a skeleton made into a structure, seen from the ground.

The solver's answer is a sequence of part ids per stage and one per key point; to put
it back on the ground the export needs where each key point stands, each stage's
polyline (through its bends) and the side its facades face, which key point a stage
leaves and reaches, and by which leg of the key part it leaves (leg 1, or leg 2 for a
T junction's branch). A corner whose key element is a joint (:func:`is_joint`) is a
mitre joint. A :class:`PlacementPlan` carries exactly that, as plain typed
data, so export reads no solver structure and no skeleton: the pipeline builds one
beside every structure it hands the solver (see
:func:`citysynth.pipeline.skeleton_to_structure.skeleton_structure`).

Key points are numbered like the structure's (key point 0 is the root, or where a
cycle is cut); stages like the structure's stages.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

Front = Literal["left", "right"]
"""The side of travel a stage's facades face (the canonical facade faces the right)."""

KeyKind = Literal["end", "corner", "t_junction"]
"""What stands at a structure key point (bends are not key points)."""

Point = tuple[float, float]

JOINT = "joint:mitre"
"""The key elements of a corner with no corner part, mitre joints, are named
``joint:mitre`` plus their legs (``joint:mitre+0.4+0.2``): the modules on either side
run to the corner, extended over the joint's legs, and are cut on its bisector plane."""


FILLED = "citysynth:middle parts"
"""The resource counting a stage's middle parts. A stage whose key parts' legs alone
come within its length interval on the solver's grid, but not within a millimetre of
its skeleton as their geometry measures, would leave a gap no middle part absorbs
(nothing is stretched between two rigid key parts): the pipeline asks such a stage for
at least one middle part on this resource. It is the pipeline's, not the user's: a
layout's asked and met intervals leave it out."""


def is_joint(element: str) -> bool:
    return element.startswith(JOINT)


def other_side(side: Front) -> Front:
    return "left" if side == "right" else "right"


@dataclass(frozen=True)
class PlanKey:
    """A structure key point on the ground."""

    xy: Point
    kind: KeyKind
    skeleton_key: int              # the skeleton key point it stands on


@dataclass(frozen=True)
class PlanStage:
    """A stage on the ground: from key point ``start`` to ``end`` along ``points``."""

    start: int
    end: int
    start_leg: int                 # the leg of the start key part it leaves by (1, or 2)
    points: tuple[Point, ...]      # its polyline, start to end, through any bends
    front: Front
    edges: tuple[int, ...]         # skeleton edge indices, in travel order
    asked: dict[str, tuple[float, float]]   # its intervals (length first)
    end_leg: int = 0               # the leg of the end key part it reaches (0, or 2)

    @property
    def length_interval(self) -> tuple[float, float]:
        return self.asked["length"]


@dataclass(frozen=True)
class PlacementPlan:
    """One skeleton (a building, or one ring of a block) ready to receive a solution."""

    name: str
    closed: bool
    style: str
    frame: str                     # the local metric frame, described for people
    keys: tuple[PlanKey, ...]
    stages: tuple[PlanStage, ...]
    branch: dict[int, int] = field(default_factory=dict)    # T key point -> branch stage
    asked: dict[str, tuple[float, float]] = field(default_factory=dict)  # whole structure
    joints: dict[str, tuple[float, float]] = field(default_factory=dict)  # id -> legs

    def incoming(self) -> dict[int, int | None]:
        """Each key point's incoming stage on its main line, by its in-leg (None where
        none enters so: a tree's root, an end whose stage leaves it). A branch that ends
        at its T (an H's bar) is not one: see :attr:`branch`."""
        ins: dict[int, int | None] = {j: None for j in range(len(self.keys))}
        for s, st in enumerate(self.stages):
            if st.end_leg == 0:
                ins[st.end] = s
        return ins

    def outgoing(self) -> dict[int, list[int]]:
        """Each key point's outgoing stages, in stage order."""
        outs: dict[int, list[int]] = {j: [] for j in range(len(self.keys))}
        for s, st in enumerate(self.stages):
            outs[st.start].append(s)
        return outs
