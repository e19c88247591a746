"""Measure a part instead of trusting its label.

Conventions (the canonical frame, documented in the README): facade and building
parts run along +X with the facade toward -Y and +Z up; floors stack along +Z.
Key-point parts have the key point at the origin and one leg per incident skeleton
edge: a corner's incoming leg along -X and its outgoing leg along the direction the
skeleton turns to (left by 180 - angle for a convex corner, right for a concave one);
a T part's legs along -X, +X and +Y. A leg's length is how far the part reaches
along its direction. Sections are taken 5 mm inside each end.
A straight part starts where its mesh starts along X and a stacked part where it starts
along Z (``Measured.origin``); placing parts subtracts that, so a library need not put
every mesh at x = 0. Key-point parts are placed by their origin, the key point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from shapely.geometry.base import BaseGeometry

from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.manifest import PartClass, PartSpec
from citysynth.parts_db.sections import body_labels, plane_section

EPS = 0.005
STRAIGHT: tuple[PartClass, ...] = ("middle", "building", "end_left", "end_right")
STACKED: tuple[PartClass, ...] = ("floor", "ground_floor", "roof")
PLAUSIBLE_LENGTH = (0.2, 150.0)  # metres along the primary axis
PLAUSIBLE_STOREY = (0.5, 30.0)   # metres of a floor, ground floor or roof
PLAUSIBLE_SPAN = (0.2, 1000.0)   # metres: the mesh's size along its largest axis


@dataclass
class Measured:
    legs: list[float]                 # primary extents: 1 for straight/stacked parts
    directions: list[tuple[float, float]]
    height: float
    floor_area: float | None
    sec_in: BaseGeometry
    sec_out: BaseGeometry
    sec_branch: BaseGeometry | None = None   # T parts: across the branch leg
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)  # where the part starts (see below)


def leg_directions(spec: PartSpec) -> list[tuple[float, float]]:
    if spec.cls == "corner":
        if spec.angle is None:   # read_manifest refuses such a corner; a hand-made spec
            raise LibraryError(f'part "{spec.id}": a corner needs an angle')
        turn = math.radians(180.0 - spec.angle) * (1 if spec.convex else -1)
        return [(-1.0, 0.0), (math.cos(turn), math.sin(turn))]
    if spec.cls == "t_junction":
        return [(-1.0, 0.0), (1.0, 0.0), (0.0, 1.0)]
    if spec.cls in STACKED:
        return []
    return [(1.0, 0.0)]


AXIS_TOLERANCE = 2.0     # degrees: a wall this near a leg's axes runs along it
AGREE_SHARE = 0.5        # of the outgoing leg's wall area: at least this must run so


def corner_disagrees(mesh, spec: PartSpec, legs: list[float]) -> str | None:
    """Whether a corner's mesh contradicts its ``angle``/``convex`` label: the walls of
    the far half of its outgoing leg (faces standing upright, by area) should run
    along the leg direction the label gives or square to it (its facade, its back, its
    end). Where less than :data:`AGREE_SHARE` of them do, the label is likely wrong
    (the leg and its section are measured along the label's direction, and the corner
    would be placed turned): the wall direction met most, in words, else None. A
    warning, not an error: a corner may carry decoration at odd angles."""
    if spec.cls != "corner" or spec.angle is None or len(legs) < 2:
        return None
    normal = mesh.triangles_cross            # (trimesh's, per face: twice the area)
    size = np.linalg.norm(normal, axis=1)
    (dx, dy) = leg_directions(spec)[1]
    along = mesh.triangles_center[:, :2] @ np.array([dx, dy])
    wall = (np.abs(normal[:, 2]) < 0.1 * size) & (size > 0) & (along > 0.5 * legs[1])
    if not wall.any():
        return None
    axis = np.degrees(np.arctan2(normal[wall, 1], normal[wall, 0])) % 180.0
    area = size[wall]
    turn = math.degrees(math.atan2(dy, dx)) % 180.0

    def near(a: np.ndarray, to: float) -> np.ndarray:
        return np.abs((a - to + 90.0) % 180.0 - 90.0) <= AXIS_TOLERANCE

    agree = area[near(axis, turn) | near(axis, turn + 90.0)].sum() / area.sum()
    if agree >= AGREE_SHARE:
        return None
    hist = np.bincount(np.round(axis).astype(int) % 180, weights=area, minlength=180)
    seen = (int(np.argmax(hist)) + 90) % 180      # the commonest wall's direction
    return (f"its outgoing leg's walls run mostly at {seen}° to its incoming leg's, where "
            f"angle = {spec.angle:g}, convex = {str(bool(spec.convex)).lower()} puts that "
            f"leg at {int(round(turn))}° (or square to it); check its angle and convex "
            "(see README, canonical frame)")


def snap_legs(measured: list[float], quantum: float) -> list[float]:
    """Measured legs snapped to the library quantum (at least one quantum each): the
    lengths the solver counts in whole quanta."""
    return [round(max(round(leg / quantum), 1) * quantum, 9) for leg in measured]


def _facade_section(mesh, direction, dist, outward_end: bool, labels):
    """Section across a leg at distance ``dist`` along ``direction`` from the origin,
    seen along the direction of travel of the sequence (into the part on an incoming
    leg, out of it on an outgoing one): u = the facade's outward normal (to the right
    of travel), v = up. In- and out-sections of all parts are then comparable."""
    d = np.array([direction[0], direction[1], 0.0])
    travel = d if outward_end else -d
    u = np.array([travel[1], -travel[0], 0.0])
    return plane_section(mesh, d * dist, travel, u, np.array([0.0, 0.0, 1.0]), labels)


def _faces_twice(mesh) -> int:
    """How many faces of ``mesh`` (its vertices merged) repeat another's corners."""
    faces = np.sort(np.asarray(mesh.faces), axis=1)
    return len(faces) - len(np.unique(faces, axis=0)) if len(faces) else 0


def _check_span(lo: np.ndarray, hi: np.ndarray, where: str) -> None:
    """A mesh no building part can be: one stray vertex a modelling tool left 1e30 m
    away (its sections then failed inside trimesh: a traceback), or a part a
    micrometre long (its sections were empty, and the user heard "not closed")."""
    span = hi - lo
    axis = int(np.argmax(span))
    lo_ok, hi_ok = PLAUSIBLE_SPAN
    if not lo_ok <= float(span[axis]) <= hi_ok:
        far = " (a stray vertex far from the rest?)" if span[axis] > hi_ok else ""
        if hi_ok < span[axis] <= 1000 * hi_ok and (span / 1000 >= lo_ok).all():
            far = ' (millimetres? set units = "mm"; or a stray vertex far from the rest?)'
        raise LibraryError(f"{where}: {float(span[axis]):g} m across along "
                           f"{'XYZ'[axis]}, implausible for a building part (expected "
                           f"{lo_ok:g}-{hi_ok:g} m){far}; check [library] units and the "
                           "mesh's vertices")


OFF_FRAME = 1.0   # m: a facade part this far from y = 0, or off the ground, is warned of


def off_frame(mesh, cls: str) -> str | None:
    """Why a part lies off its canonical frame, or None: a facade part's facade far from
    the plane y = 0 the skeleton line runs in, or its body not on the ground z = 0; a
    tower part's plan not reaching the vertical axis its storeys stack along. Ingest
    measured such a part as any other, and a building stood 100 km behind its street
    (a part exported with its world position) or buried 50 m deep, its preview framed
    on it and looking right."""
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    if cls in STACKED:   # storeys stack about the vertical axis: a floor off it overhung
        off = max(lo[0], -hi[0], lo[1], -hi[1])   # by 8 m, told only by a high cost
        if off <= OFF_FRAME:
            return None
        return (f"its plan (x {float(lo[0]):g} to {float(hi[0]):g} m, y {float(lo[1]):g} to "
                f"{float(hi[1]):g} m) lies {float(off):g} m off the vertical axis x = y = 0 "
                "that a tower's storeys stack along; move it to its canonical frame (see "
                "README)")
    if lo[1] > OFF_FRAME or hi[1] < -OFF_FRAME:
        far = float(lo[1] if lo[1] > 0 else -hi[1])
        side = "behind" if lo[1] > 0 else "in front of"
        return (f"it lies {far:g} m {side} the facade plane y = 0 (the skeleton line); "
                "move it to its canonical frame (see README)")
    if lo[2] > OFF_FRAME or hi[2] < 0.0:
        return (f"its lowest point is at z = {float(lo[2]):g} m, not on the ground "
                "z = 0; move it to its canonical frame (see README)")
    return None


def measure(mesh, spec: PartSpec, where: str) -> Measured:
    v = mesh.vertices
    lo, hi = v.min(axis=0), v.max(axis=0)
    _check_span(lo, hi, where)
    labels = body_labels(mesh)
    height = float(hi[2] - lo[2])
    if spec.cls in STACKED:
        lo_ok, hi_ok = PLAUSIBLE_STOREY
        if not lo_ok <= height <= hi_ok:
            raise LibraryError(f"{where}: {height:g} units tall along +Z, implausible for a "
                               f"{spec.cls} (expected {lo_ok:g}-{hi_ok:g} m); check "
                               "[library] units and that +Z is up")
        xy = (np.eye(3)[0], np.eye(3)[1])
        sec_in = plane_section(mesh, [0, 0, lo[2] + EPS], [0, 0, 1], *xy, labels)
        sec_out = plane_section(mesh, [0, 0, hi[2] - EPS], [0, 0, 1], *xy, labels)
        mid = plane_section(mesh, [0, 0, (lo[2] + hi[2]) / 2], [0, 0, 1], *xy, labels)
        m = Measured([height], [], height, float(mid.area), sec_in, sec_out,
                     origin=(0.0, 0.0, float(lo[2])))
    elif spec.cls in STRAIGHT:
        length = float(hi[0] - lo[0])
        if length < PLAUSIBLE_LENGTH[0]:   # before its sections: a 1 µm one has none
            _check_length(length, where, float(np.abs(v).max()))
        d = (1.0, 0.0)
        sec_in = _facade_section(mesh, d, lo[0] + EPS, True, labels)
        sec_out = _facade_section(mesh, d, hi[0] - EPS, True, labels)
        m = Measured([length], [d], height, None, sec_in, sec_out,
                     origin=(float(lo[0]), 0.0, 0.0))
    else:
        dirs = leg_directions(spec)
        legs = [float(max((v[:, :2] @ np.array(d)).max(), 0.0)) for d in dirs]
        for d, leg in zip(dirs, legs, strict=True):
            if leg < EPS * 4:
                raise LibraryError(
                    f"{where}: reaches only {leg:g} along its leg direction "
                    f"({d[0]:.3g}, {d[1]:.3g}); a {spec.cls} needs geometry along each leg "
                    "(see README, canonical frame)")
        sec_in = _facade_section(mesh, dirs[0], legs[0] - EPS, False, labels)
        sec_out = _facade_section(mesh, dirs[1], legs[1] - EPS, True, labels)
        m = Measured(legs, dirs, height, None, sec_in, sec_out)
        if spec.cls == "t_junction":
            m.sec_branch = _facade_section(mesh, dirs[2], legs[2] - EPS, True, labels)
    for name, sec in (("in", m.sec_in), ("out", m.sec_out), ("branch", m.sec_branch)):
        if sec is not None and (sec.is_empty or sec.area <= 0):
            twice = _faces_twice(mesh)
            if twice:   # two coincident copies cancel out: each loop a hole in the other
                raise LibraryError(f"{where}: no cross-section at its {name}-end: the mesh "
                                   f"holds {twice:,} of its faces twice (two coincident "
                                   "copies of a body, as a double export leaves); delete the "
                                   "copy in the modelling tool and export again")
            raise LibraryError(f"{where}: no cross-section at its {name}-end; the mesh must "
                               "be closed and reach both ends of its primary axis")
    if spec.cls not in STACKED:
        total = sum(m.legs)
        if spec.length is not None and not 0.8 <= total / spec.length <= 1.25:
            ratio = total / spec.length
            hint = _units_hint(ratio)
            raise LibraryError(f"{where}: measures {total:g} m along its primary axis but the "
                               f"manifest says {spec.length:g} m{hint}; check [library] "
                               "units and the canonical frame")
        _check_length(total, where, float(np.abs(mesh.vertices).max()))
    return m


_SCALES = {"cm": 100.0, "mm": 1000.0, "in": 1 / 0.0254, "ft": 1 / 0.3048}
_NAMES = {"cm": "centimetres", "mm": "millimetres", "in": "inches", "ft": "feet"}


def _units_hint(ratio: float) -> str:
    """What a part measured ``ratio`` times the length the manifest gives suggests: a
    mesh in other units than [library] units says, by a factor a unit explains (only
    centimetres were told: a mesh in millimetres, or one in metres under units = "cm",
    got no hint)."""
    for unit, factor in _SCALES.items():
        if abs(math.log(ratio / factor)) < math.log(1.1):
            return f' (it looks like {_NAMES[unit]}: set units = "{unit}")'
        if abs(math.log(ratio * factor)) < math.log(1.1):
            return (f" (it measures 1/{factor:.4g} of the length given: a mesh in metres "
                    f'under units = "{unit}"?)')
    return ""


def _check_length(total: float, where: str, far: float = 0.0) -> None:
    """A part's length along its primary axis is a building part's. A part far from its
    origin (``far``: its farthest coordinate) is told so where that explains a length
    lost: a 5 m part 1,000,000 km out measured 0 m, its 32-bit coordinates one step."""
    lo_ok, hi_ok = PLAUSIBLE_LENGTH
    if not lo_ok <= total <= hi_ok:
        step = float(np.spacing(np.float32(far)))
        cause = (f" (its points lie {far:,.0f} m from its origin, where a file's 32-bit "
                 f"coordinates step by {step:,.2g} m: move it to its canonical frame and "
                 "export again)") if step > lo_ok / 10 else ""
        raise LibraryError(f"{where}: {total:g} m along its primary axis is implausible "
                           f"(expected {lo_ok:g}-{hi_ok:g} m){cause}; check [library] units")


FLOAT32_FORMATS = {".glb", ".gltf", ".stl"}   # store a point's coordinates as 32-bit floats
COARSE_STEP = 0.001   # m: a float32 coordinate stepping by more than this is warned of


def coarse_floats(mesh, suffix: str, meters_per_unit: float) -> str | None:
    """Why a part stored far from its origin in a format of 32-bit floats has lost its
    measure, or None. Such a float steps by 1 m at 10,000 km: a 5.1 m box 20,000 km
    along X was measured 6.0 m, at 1,000 km 5.125 m, without a word."""
    if suffix.lower() not in FLOAT32_FORMATS or not len(mesh.vertices):
        return None
    far = float(np.abs(mesh.vertices).max()) / meters_per_unit   # in the file's units
    step = float(np.spacing(np.float32(far))) * meters_per_unit
    if step <= COARSE_STEP:
        return None
    return (f"its points lie up to {far * meters_per_unit:,.0f} m from its origin, where "
            f"the file's 32-bit coordinates step by {step * 1000:,.0f} mm: its lengths are "
            "off by as much; move it to its canonical frame (see README) and export again")


def inside_out(mesh) -> str | None:
    """Why a closed part's faces point into it (its volume negative), or None: such a
    part was ingested and exported as it is, every face turned away from the viewer
    (an engine culling back faces shows its inside)."""
    if not mesh.is_watertight or mesh.volume >= 0:
        return None
    return ("its faces point inwards (a closed mesh of negative volume): flip its normals "
            "in the modelling tool (Blender: Mesh > Normals > Recalculate Outside) and "
            "export again")
