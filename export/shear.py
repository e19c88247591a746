"""Shear in placements. A corner adapted to an angle off its own places its part with
axes that are not perpendicular (a shear). glTF forbids shear in a node matrix, and
Blender's USD importer drops it (it decomposes a transform into location, rotation
and scale: 193 instances of the demo district moved by up to 4.8 cm, so adapted
corners gaped or overlapped their walls in Blender alone). Both writers therefore
bake a sheared instance's shear into its geometry: the glTF writer the whole placement
(:mod:`.gltf`), the USD writer only the shear (:mod:`.usd`), so the instance keeps a
matrix of rotation, scale and translation that every DCC reads alike."""

from __future__ import annotations

from citysynth.export.layout import Instance
from citysynth.parts_db.geometry import Piece


def sheared(inst: Instance) -> bool:
    """Whether the placement shears by more than
    :data:`~citysynth.export.layout.SHEAR_TOL` (``inst.shear``)."""
    return inst.shear != 0.0


def perpendicular_y(inst: Instance, h: float) -> tuple[float, float]:
    """The instance's Y axis less its shear ``h`` (``inst.shear``)."""
    (xx, xy), (yx, yy) = inst.x_axis, inst.y_axis
    return (yx - h * xx, yy - h * xy)


def baked_prototype(inst: Instance) -> str:
    """The prototype a writer that bakes the shear shows for ``inst``: its part or cut
    prototype (``inst.proto``), or for a sheared placement that prototype sheared
    (``part~key~shear_p0.123456789``, one per shear to 1e-9; a USD layer's own cuts
    file holds it)."""
    h = inst.shear
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
