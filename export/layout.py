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

import hashlib
import json
import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from citysynth.export.errors import ExportError

SCHEMA = "citysynth.layout"
VERSION = 3           # 2: instances may carry a cut (mitre joints, folds); stages a polyline
#                       3: a footprint's roof infill
READS = (1, 2, 3)
COORD_DIGITS = 4      # 0.1 mm
AXIS_DIGITS = 6
VALUE_DIGITS = 6
WHOLE = 1e6            # m: a blank plane's span (u0, u1) = (-WHOLE, WHOLE) is all along

SHEAR_TOL = 1e-4   # relative; below it (~0.006°, under 2 mm over a part) an engine may drop it


@dataclass(frozen=True)
class Cut:
    """How an instance's part is cut to meet its neighbours at a joint or a fold: its
    ends first extended by ``extend`` (start, end; metres along the part's own axis, by
    stretching a thin band at each end, so walls and cornices run on), then kept where
    ``a*x + b*y <= c`` for every plane (vertical planes, in the part's placement frame),
    each cut face capped. Rounded so equal cuts are one prototype. ``blank`` holds those
    of the planes that are a wall shared with a neighbour (a party wall), each as
    (a, b, c, u0, u1): its cap is solid, without the openings (window recesses) the
    section has there, between u0 and u1 along the plane (the part-frame point's dot
    with (-b, a)): where the neighbour stands, so a party wall above a lower neighbour
    reads as a blank firewall, not as a facade, and the same wall on past the
    neighbour's end, over a yard, keeps its windows."""

    extend: tuple[float, float] = (0.0, 0.0)
    planes: tuple[tuple[float, float, float], ...] = ()
    blank: tuple[tuple[float, float, float, float, float], ...] = ()

    @cached_property
    def key(self) -> str:
        """A short name for the cut (part prototypes are named part~key); made once per
        cut, as a block's writers ask for it hundreds of times. A cut without blank
        planes keeps the name it had before they existed."""
        parts = [self.extend, self.planes] + ([self.blank] if self.blank else [])
        return hashlib.sha256(json.dumps(parts).encode()).hexdigest()[:10]

    def to_dict(self) -> dict:
        d = {"extend": list(self.extend), "planes": [list(p) for p in self.planes]}
        if self.blank:
            d["blank"] = [list(p) for p in self.blank]
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Cut:
        ext = d.get("extend", [0.0, 0.0])

        planes = tuple((float(a), float(b), float(c)) for a, b, c in d.get("planes", []))
        # a blank plane without its span (files of 2026-11-29) is solid all along
        blank = tuple((float(a), float(b), float(c), float(u0), float(u1)) for a, b, c, u0, u1
                      in ([*p, -WHOLE, WHOLE][:5] for p in d.get("blank", [])))
        return cls((float(ext[0]), float(ext[1])), planes, blank)


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
    cut: Cut | None = None     # a mitre joint or a fold: the part cut (and extended)
    z: float = 0.0             # lifted by this much (a tower's stacked floors); else 0

    @cached_property
    def shear(self) -> float:
        """``h`` with ``y_axis = h * x_axis + y_perp`` (``y_perp`` perpendicular to
        ``x_axis``), 0.0 under :data:`SHEAR_TOL`: the placement is the part frame's shear
        ``x += h * y``, then perpendicular axes (see :mod:`.shear`, whose writers ask
        for it several times an instance: computed once)."""
        x, y = np.asarray(self.x_axis), np.asarray(self.y_axis)
        if abs(float(x @ y)) <= SHEAR_TOL * float(np.linalg.norm(x) * np.linalg.norm(y)):
            return 0.0
        return float(x @ y) / float(x @ x)

    @cached_property
    def proto(self) -> str:
        """The prototype this instance shows: its part, or the part cut (``part~key``)."""
        return self.part if self.cut is None else f"{self.part}~{self.cut.key}"

    def matrix(self) -> np.ndarray:
        """4x4, column vectors (p' = M @ p): the affine map in XY, Z unchanged."""
        m = np.eye(4)
        m[:2, 0] = self.x_axis
        m[:2, 1] = self.y_axis
        m[:2, 3] = self.origin
        m[2, 3] = self.z
        return m

    def apply(self, xy) -> np.ndarray:
        """Map placement-frame XY point(s) into the layout frame."""
        p = np.asarray(xy, dtype=float)
        a = np.array([self.x_axis, self.y_axis]).T
        return p @ a.T + np.asarray(self.origin)

    @property
    def mirrored(self) -> bool:
        return self.x_axis[0] * self.y_axis[1] - self.x_axis[1] * self.y_axis[0] < 0


@dataclass(frozen=True)
class Infill:
    """A flat mass over ground of a footprint no part covers (see
    :mod:`citysynth.export.infill`): its plan (a shell anticlockwise, then holes
    clockwise, each ring without its closing point, in the layout frame), its top's
    height, and the part whose roof and wall materials it shows."""

    part: str
    z: float
    rings: tuple[tuple[tuple[float, float], ...], ...]

    def to_dict(self) -> dict:
        return {"part": self.part, "z": round(self.z, COORD_DIGITS),
                "rings": [[[round(x, COORD_DIGITS), round(y, COORD_DIGITS)] for x, y in r]
                          for r in self.rings]}

    @classmethod
    def from_dict(cls, d: dict) -> Infill:
        return cls(d["part"], float(d["z"]),
                   tuple(tuple((float(x), float(y)) for x, y in r) for r in d["rings"]))


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
    infill: list[Infill] = field(default_factory=list)   # a footprint's roof infill

    @property
    def cost(self) -> float:
        return float(sum(s["cost"] for s in self.structures))

    def parts_used(self) -> list[str]:
        return sorted({i.part for i in self.instances})

    def prototypes(self) -> dict[str, Instance]:
        """Every prototype the layout shows, with one instance that shows it."""
        out: dict[str, Instance] = {}
        for i in self.instances:
            out.setdefault(i.proto, i)
        return dict(sorted(out.items()))

    def to_dict(self) -> dict:
        return _rounded({
            "schema": SCHEMA, "version": VERSION, "name": self.name, "rank": self.rank,
            "library": self.library, "style": self.style, "frame": self.frame,
            "cost": self.cost, "parts_used": self.parts_used(),
            "structures": self.structures,
            "instances": [_instance_dict(i) for i in self.instances],
            "infill": [f.to_dict() for f in self.infill],
        })

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), sort_keys=True, indent=1, ensure_ascii=False) + "\n"

    @classmethod
    def from_dict(cls, d: dict) -> Layout:
        """A layout read back from its JSON (``json.load`` of a ``.layout.json``).

        >>> lay = Layout("b", 1, {"name": "lib", "hash": "h", "quantum": 0.2}, "classic",
        ...              "local", [{"cost": 1.5}],
        ...              [Instance("mid", "middle", 0, 0, None, (1.0, 0.0), (0.0, 1.0),
        ...                        (2.0, 3.0), Cut((0.0, 0.4), ((1.0, 0.0, 2.6),)))])
        >>> back = Layout.from_dict(json.loads(lay.to_json()))
        >>> back.cost, back.instances[0].proto == lay.instances[0].proto, back == lay
        (1.5, True, True)
        >>> Layout.from_dict({"schema": "something else"})
        Traceback (most recent call last):
          ...
        citysynth.export.errors.ExportError: not a citysynth.layout document of version 1, 2 or 3
        """
        if d.get("schema") != SCHEMA or d.get("version") not in READS:
            raise ExportError(f"not a {SCHEMA} document of version "
                              f"{', '.join(map(str, READS[:-1]))} or {READS[-1]}")
        inst = [Instance(i["part"], i["class"], i["structure"], i.get("stage"),
                         i.get("key"), tuple(i["x_axis"]), tuple(i["y_axis"]),
                         tuple(i["origin"]),
                         Cut.from_dict(i["cut"]) if "cut" in i else None,
                         float(i.get("z", 0.0)))
                for i in d["instances"]]
        return cls(d["name"], d["rank"], d["library"], d["style"], d["frame"],
                   d["structures"], inst, [Infill.from_dict(f) for f in d.get("infill", [])])


def _instance_dict(i: Instance) -> dict:
    d = {"part": i.part, "class": i.cls, "structure": i.structure,
         "x_axis": [round(v, AXIS_DIGITS) for v in i.x_axis],
         "y_axis": [round(v, AXIS_DIGITS) for v in i.y_axis],
         "origin": [round(v, COORD_DIGITS) for v in i.origin]}
    if i.stage is not None:
        d["stage"] = i.stage
    if i.key is not None:
        d["key"] = i.key
    if i.cut is not None:
        d["cut"] = i.cut.to_dict()
    if i.z:
        d["z"] = round(i.z, COORD_DIGITS)
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
