"""Skeletons as plain data: key points and edges in a local metric frame.

A skeleton is what the structure solver consumes: key points (where a key-point part
must stand: an end, a corner of some angle, a T junction; or a bend too straight to
need a corner part) and edges between them, each with its length, the side its
facade faces, and its own resource intervals. Closed skeletons (footprint and block
outlines) are cycles. networkx holds the graph for the checks and decompositions.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal, get_args

import networkx as nx

from citysynth.skeletons.geojson import Frame

KeyPointKind = Literal["end", "corner", "bend", "t_junction"]
Front = Literal["left", "right"]       # the side of an edge's direction its facade faces
KINDS: tuple[KeyPointKind, ...] = get_args(KeyPointKind)
FRONTS: tuple[Front, ...] = get_args(Front)


def flip(side: Front) -> Front:
    """The other side."""
    return "left" if side == "right" else "right"


@dataclass(frozen=True)
class KeyPoint:
    id: int
    xy: tuple[float, float]
    kind: KeyPointKind
    degree: int
    angle: float | None = None     # corners, bends: degrees between the two legs (0-180)
    convex: bool | None = None     # corners, bends: True when the facade turns around the mass
    turn: float | None = None      # corners and bends: signed turn along the path (deg)
    branch: int | None = None      # T junctions: index of the edge that branches off


@dataclass(frozen=True)
class Edge:
    a: int
    b: int
    length: float
    front: Front                   # of the direction a -> b
    constraints: dict[str, tuple[float, float]] = field(default_factory=dict)
    source: str = ""               # the input feature it came from


@dataclass
class Skeleton:
    name: str
    keypoints: list[KeyPoint]
    edges: list[Edge]
    closed: bool
    frame: Frame

    def graph(self) -> nx.Graph:
        g = nx.Graph()
        for k in self.keypoints:
            g.add_node(k.id, xy=k.xy, kind=k.kind)
        for i, e in enumerate(self.edges):
            g.add_edge(e.a, e.b, index=i, length=e.length)
        return g

    @property
    def length(self) -> float:
        return sum(e.length for e in self.edges)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "closed": self.closed, "frame": self.frame.describe(),
                "keypoints": [asdict(k) for k in self.keypoints],
                "edges": [asdict(e) for e in self.edges]}
