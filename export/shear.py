"""Shear in placements. A corner adapted to an angle off its own places its part with
axes that are not perpendicular (a shear). glTF forbids shear in a node matrix, and
Blender's USD importer drops it (it decomposes a transform into location, rotation
and scale: 193 instances of the demo district moved by up to 4.8 cm, so adapted
corners gaped or overlapped their walls in Blender alone). Both writers therefore
bake a sheared instance's shear into its geometry: the glTF writer the whole placement
(:mod:`.gltf`), the USD writer only the shear (:mod:`.usd`), so the instance keeps a
matrix of rotation, scale and translation that every DCC reads alike."""

from __future__ import annotations

import numpy as np

from citysynth.export.layout import Instance
from citysynth.parts_db.geometry import Piece

SHEAR_TOL = 1e-4   # relative; below it (~0.006°, under 2 mm over a part) an engine may drop it


def sheared(inst: Instance) -> bool:
    x, y = np.asarray(inst.x_axis), np.asarray(inst.y_axis)
    return abs(float(x @ y)) > SHEAR_TOL * float(np.linalg.norm(x) * np.linalg.norm(y))


def shear_of(inst: Instance) -> float:
    """``h`` with ``y_axis = h * x_axis + y_perp`` (``y_perp`` perpendicular to
    ``x_axis``), 0.0 for an instance not :func:`sheared`: the placement is the part
    frame's shear ``x += h * y`` (:func:`sheared_pieces`), then the perpendicular axes
    ``x_axis`` and :func:`perpendicular_y`."""
    if not sheared(inst):
        return 0.0
    x, y = np.asarray(inst.x_axis), np.asarray(inst.y_axis)
    return float(x @ y) / float(x @ x)


def perpendicular_y(inst: Instance, h: float) -> tuple[float, float]:
    """The instance's Y axis less its shear ``h`` (:func:`shear_of`)."""
    (xx, xy), (yx, yy) = inst.x_axis, inst.y_axis
    return (yx - h * xx, yy - h * xy)


def baked_prototype(inst: Instance) -> str:
    """The prototype a writer that bakes the shear shows for ``inst``: its part or cut
    prototype (``inst.proto``), or for a sheared placement that prototype sheared
    (``part~key~shear_p0.123456789``, one per shear to 1e-9; a USD layer's own cuts
    file holds it)."""
    h = shear_of(inst)
    if not h:
        return inst.proto
    return f"{inst.proto}~shear_{'m' if h < 0 else 'p'}{abs(h):.9f}"


def sheared_pieces(pieces: tuple[Piece, ...], h: float) -> tuple[Piece, ...]:
    """``pieces`` (a part's placement frame) sheared by ``h``: x += h * y. The faces
    keep their winding (a shear keeps orientation)."""
    if h == 0.0:
        return pieces
    out = []
    for p in pieces:
        v = p.vertices.copy()
        v[:, 0] += h * v[:, 1]
        out.append(Piece(p.name, p.rgba, v, p.faces))
    return tuple(out)
