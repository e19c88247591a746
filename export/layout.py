"""Layouts: a solved structure put back on its skeleton, as plain data and JSON.

A :class:`Layout` is what every exporter reads: each part instance with its part id
and its placement (where the part's frame lands: the images of its +X and +Y axes and
of its origin, in the skeleton's local metric frame; +Z stays up), grouped by
structure (one per skeleton: a building, or a block ring) with the stages' stretch,
constraints asked and resources met. Its JSON is versioned and deterministic to the
byte (sorted keys, fixed precision, no timings), so two runs can be compared with
``diff``; the schema is in the README.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

SCHEMA = "citysynth.layout"
VERSION = 1
COORD_DIGITS = 4      # 0.1 mm
AXIS_DIGITS = 6
VALUE_DIGITS = 6


@dataclass(frozen=True)
class Instance:
    """One placed part. Its matrix maps the part's placement frame (see
    :mod:`parts_db.geometry`) into the layout frame: x_axis and y_axis are the images
    of the unit X and Y vectors (a stretch, a mirror or, at a corner adapted to its
    angle, a shear), origin the image of the origin."""

    part: str
    cls: str
    structure: int
    stage: int | None          # fillers: the stage they fill
    key: int | None            # key-point parts: the structure key point
    x_axis: tuple[float, float]
    y_axis: tuple[float, float]
    origin: tuple[float, float]

    def matrix(self) -> np.ndarray:
        """4x4, column vectors (p' = M @ p): the affine map in XY, Z unchanged."""
        m = np.eye(4)
        m[:2, 0] = self.x_axis
        m[:2, 1] = self.y_axis
        m[:2, 3] = self.origin
        return m

    def apply(self, xy) -> np.ndarray:
        """Map placement-frame XY point(s) into the layout frame."""
        p = np.asarray(xy, dtype=float)
        a = np.array([self.x_axis, self.y_axis]).T
        return p @ a.T + np.asarray(self.origin)

    @property
    def mirrored(self) -> bool:
        return self.x_axis[0] * self.y_axis[1] - self.x_axis[1] * self.y_axis[0] < 0


@dataclass
class Layout:
    """A building or a block: one or more structures and all their placed parts."""

    name: str
    rank: int                          # 1 = best of the k solved
    library: dict                      # name, hash, quantum
    style: str
    frame: str
    structures: list[dict]             # per structure: keys, stages, cost, resources
    instances: list[Instance] = field(default_factory=list)

    @property
    def cost(self) -> float:
        return float(sum(s["cost"] for s in self.structures))

    def parts_used(self) -> list[str]:
        return sorted({i.part for i in self.instances})

    def to_dict(self) -> dict:
        return _rounded({
            "schema": SCHEMA, "version": VERSION, "name": self.name, "rank": self.rank,
            "library": self.library, "style": self.style, "frame": self.frame,
            "cost": self.cost, "parts_used": self.parts_used(),
            "structures": self.structures,
            "instances": [_instance_dict(i) for i in self.instances],
        })

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, indent=1, ensure_ascii=False) + "\n"

    @classmethod
    def from_dict(cls, d: dict) -> Layout:
        if d.get("schema") != SCHEMA or d.get("version") != VERSION:
            raise ValueError(f"not a {SCHEMA} version {VERSION} document")
        inst = [Instance(i["part"], i["class"], i["structure"], i.get("stage"),
                         i.get("key"), tuple(i["x_axis"]), tuple(i["y_axis"]),
                         tuple(i["origin"])) for i in d["instances"]]
        return cls(d["name"], d["rank"], d["library"], d["style"], d["frame"],
                   d["structures"], inst)


def _instance_dict(i: Instance) -> dict:
    d = {"part": i.part, "class": i.cls, "structure": i.structure,
         "x_axis": [round(v, AXIS_DIGITS) for v in i.x_axis],
         "y_axis": [round(v, AXIS_DIGITS) for v in i.y_axis],
         "origin": [round(v, COORD_DIGITS) for v in i.origin]}
    if i.stage is not None:
        d["stage"] = i.stage
    if i.key is not None:
        d["key"] = i.key
    return d


def _rounded(x):
    """Floats to fixed precision (and never -0.0), recursively, so the JSON text is a
    function of the values only."""
    if isinstance(x, float):
        if not math.isfinite(x):
            raise ValueError(f"non-finite number {x} in a layout")
        r = round(x, VALUE_DIGITS)
        return 0.0 if r == 0 else r
    if isinstance(x, dict):
        return {str(k): _rounded(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_rounded(v) for v in x]
    if isinstance(x, np.generic):
        return _rounded(x.item())
    return x
