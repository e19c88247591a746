"""Part prototypes cut for mitre joints and folds.

Where two facade runs meet at an angle no corner part fits, or where a run bends under
a part, the modules meeting there are cut along the joint's bisector plane and the cut
is capped, so walls, cornices and roofs meet exactly, convex or concave, at any angle.
A :class:`~citysynth.export.layout.Cut` says how, in the part's own placement frame:

1. **Extend.** Where the bisector plane lies beyond a part's end (behind a concave
   corner, or in front of a convex one, where a cornice overhangs), the part's end is
   first extended by stretching a thin band at that end (:data:`BAND` wide): a wall or
   cornice face that runs to the end runs on, with its profile, and nothing else moves.
2. **Cut.** Every face is clipped to the kept side of each plane
   (:func:`~citysynth.export.clip.clip`, compiled, which keeps what trimesh's
   ``slice_faces_plane`` keeps, all pieces in one pass), each face staying in its
   piece, so each keeps its material (the pieces parted again in one compiled pass,
   :func:`~citysynth.export.clip.split`).
3. **Cap.** The part's solid cross-section on each plane (the even-odd section of its
   bodies, as ingest measures sections; taken from the section's segments chained
   into loops where they chain simply, the same polygons without noding them, and
   where those loops lie plainly apart, as most do, triangulated straight from them
   without shapely) is triangulated and added to the walls piece, facing out of the
   cut, so the cut part is closed again. On a blank plane (a party wall) the section's
   holes are filled first: the window openings a wall's section has there are not
   part of a party wall.

The cut pieces of a (part, cut) pair are computed once per process and, being plain
prototypes, are instanced by USD and glTF like any part.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import shapely
import trimesh
from mapbox_earcut import triangulate_float64
from shapely.geometry import box

from citysynth.export.clip import clip, split
from citysynth.export.layout import WHOLE, Cut
from citysynth.parts_db import Part, PartDB
from citysynth.parts_db.geometry import Piece, part_pieces
from citysynth.parts_db.sections import (
    NO_RINGS,
    Rings,
    body_labels,
    loop_section,
    plain_rings_section,
    plane_section,
)

BAND = 0.02            # m at each end of a part: what an extension stretches
CACHED_CUTS = 1024     # cut prototypes kept per process (a building has tens)
_CACHE: OrderedDict[tuple[str, str, Cut], tuple[Piece, ...]] = OrderedDict()
_LABELS: dict[tuple[str, str], np.ndarray] = {}
CAP_PIECE = "walls"    # the material a cap takes (else the part's first piece's)
POLYGON = shapely.GeometryType.POLYGON


def cut_pieces(db: PartDB, part: Part, cut: Cut) -> tuple[Piece, ...]:
    """The pieces of ``part`` extended, cut and capped as ``cut`` says (cached: the k
    layouts of a building mostly cut the same joints; a cut is seldom met again in
    another building, so only the last :data:`CACHED_CUTS` are kept, and a worker
    building thousands of blocks does not hold every cut it ever made)."""
    key = (db.library_hash, part.id, cut)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    pieces = part_pieces(db, part)
    labels = _LABELS.get(key[:2])
    if labels is None:   # which body each face belongs to: the same for every cut
        labels = _LABELS[key[:2]] = _body_labels(pieces)
    out = _CACHE[key] = _cut(pieces, length(part), cut, labels)
    if len(_CACHE) > CACHED_CUTS:
        _CACHE.popitem(last=False)
    return out


def _body_labels(pieces: tuple[Piece, ...]) -> np.ndarray:
    """The closed body each face of the part belongs to, as ingest sees it: on the
    vertex-merged mesh (the pieces repeat a vertex where two materials meet, so on the
    pieces as given a closed body falls apart into open patches, whose sections are
    dropped, and the cut was left uncapped)."""
    whole = _whole(pieces, [p.vertices for p in pieces])
    whole.merge_vertices()
    return body_labels(whole)


def length(part: Part) -> float:
    """A straight part's length along X in its placement frame."""
    return float(part.legs_measured[0] * part.scale)


def extended_x(x: np.ndarray, length: float | np.ndarray, ext) -> np.ndarray:
    """Placement-frame x coordinates with each end of the part moved out by ext[0]
    (start, -X) and ext[1] (end, +X), stretching only the band of :data:`BAND` at that
    end; ``length`` and ``ext`` (start, end) one for all or one per coordinate (the roof
    infill extends a footprint's instances all at once)."""
    x = np.array(x, dtype=float)
    if np.ndim(length) == 0 and np.shape(ext) == (2,):   # one part: plain floats
        return _extended_one(x, float(length), float(ext[0]), float(ext[1]))
    length_ = np.broadcast_to(np.asarray(length, dtype=float), x.shape)
    start, end = np.broadcast_to(np.asarray(ext, dtype=float), (*x.shape, 2)).T
    band = np.minimum(BAND, length_ / 4)
    at = (end > 0) & (x > length_ - band)
    x[at] = (length_ - band)[at] + (x[at] - (length_ - band)[at]) * (band + end)[at] / band[at]
    at = (start > 0) & (x < band)
    x[at] = band[at] - (band[at] - x[at]) * (band + start)[at] / band[at]
    return x


def _extended_one(x: np.ndarray, length: float, start: float, end: float) -> np.ndarray:
    """:func:`extended_x` of one part's coordinates ``x`` (moved in place) with the
    arithmetic of its arrays, in plain floats: a city extends tens of parts a block,
    and the broadcasting took a third of a cut's time."""
    band = min(BAND, length / 4)
    if end > 0:
        at = x > length - band
        x[at] = (length - band) + (x[at] - (length - band)) * (band + end) / band
    if start > 0:
        at = x < band
        x[at] = band - (band - x[at]) * (band + start) / band
    return x


def _whole(pieces: tuple[Piece, ...], vertices: list[np.ndarray]) -> trimesh.Trimesh:
    """All pieces as one mesh (vertices given per piece, e.g. extended)."""
    return trimesh.Trimesh(*_joined(pieces, vertices), process=False)


def _joined(pieces: tuple[Piece, ...], vertices: list[np.ndarray]
            ) -> tuple[np.ndarray, np.ndarray]:
    """All pieces' vertices and faces as one mesh's arrays (no trimesh object: a cut
    only needs one where its cap falls back to plane_section)."""
    return (np.concatenate(vertices),
            np.concatenate(_offset_faces([p.faces for p in pieces], [len(v) for v in vertices])))


def _cut(pieces: tuple[Piece, ...], length_: float, cut: Cut,
         labels: np.ndarray) -> tuple[Piece, ...]:
    whole_v, whole_f = _joined(pieces, [p.vertices for p in pieces])   # new arrays
    if cut.extend != (0.0, 0.0):   # all pieces at once, in one call
        whole_v[:, 0] = extended_x(whole_v[:, 0], length_, cut.extend)
    verts, faces = whole_v, whole_f
    owner = np.repeat(np.arange(len(pieces)), [len(p.faces) for p in pieces])
    for plane in cut.planes:
        verts, faces, source = clip(verts, faces, plane)
        owner = owner[source]
    out: list[Piece] = []
    used, used_ends, local, face_ends = split(len(verts), faces, owner, len(pieces))
    for i, piece in enumerate(pieces):
        if face_ends[i + 1] > face_ends[i]:
            out.append(Piece(piece.name, piece.rgba,
                             verts[used[used_ends[i]:used_ends[i + 1]]],
                             local[face_ends[i]:face_ends[i + 1]]))
    solid: dict[tuple[float, float, float], list[tuple[float, float]]] = {}
    for a, b, c, u0, u1 in cut.blank:     # (a wall may have two neighbours along it)
        solid.setdefault((a, b, c), []).append((u0, u1))
    caps = [c for c in (_cap(whole_v, whole_f, plane, cut.planes, labels,
                             solid=solid.get(plane))
                        for plane in cut.planes) if c is not None]
    # a piece whose every face was a needle goes: kept with its points and no face it
    # was an empty mesh, which glTF forbids (city.glb failed the Khronos validator)
    kept = (_cleaned(p) for p in (_with_caps(out, pieces, caps) if caps else out))
    return tuple(p for p in kept if len(p.faces))


NEEDLE = 1e-6   # m: a triangle this thin (twice its area over its longest side) is a line


def _cleaned(piece: Piece) -> Piece:
    """``piece`` without the triangles of no area that clipping at a vertex and capping
    along collinear points leave: a face whose corners coincide or lie on one line
    (edges 5.89, 0 and 5.89 m). They cover nothing, but trimesh and a renderer's
    checks count them as degenerate (1,535 in the demo district's city.glb). Points no
    face uses go too (those of the needles, and a cap's collinear section points its
    triangulation left out): kept, a DCC imports them as loose vertices (1 % of the demo
    district's cut points were)."""
    f = piece.faces
    a, b, c = piece.vertices[f[:, 0]], piece.vertices[f[:, 1]], piece.vertices[f[:, 2]]
    ab, bc, ca = b - a, c - b, a - c
    # |ab x bc| spelled out: np.cross took half of this function's time (27,000 calls
    # on a 100-block city), for the same floats
    x = ab[:, 1] * bc[:, 2] - ab[:, 2] * bc[:, 1]
    y = ab[:, 2] * bc[:, 0] - ab[:, 0] * bc[:, 2]
    z = ab[:, 0] * bc[:, 1] - ab[:, 1] * bc[:, 0]
    area2 = np.sqrt(x * x + y * y + z * z)
    longest = np.sqrt(np.maximum(np.maximum((ab * ab).sum(axis=1), (bc * bc).sum(axis=1)),
                                 (ca * ca).sum(axis=1)))
    keep = area2 > NEEDLE * longest
    return piece.with_faces(f if keep.all() else f[keep])


def _offset_faces(faces: list[np.ndarray], counts: list[int]) -> list[np.ndarray]:
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return [f + o for f, o in zip(faces, offsets, strict=True)]


def _cap(mesh_v: np.ndarray, mesh_f: np.ndarray, plane: tuple[float, float, float],
         planes: tuple[tuple[float, float, float], ...], labels: np.ndarray,
         solid: list[tuple[float, float]] | None = None
         ) -> tuple[np.ndarray, np.ndarray] | None:
    """The triangulated cross-section of the part (its extended mesh: mesh_v, mesh_f)
    on ``plane`` (within the other planes), facing out of the kept side: (vertices,
    faces), or None when empty. The section is ingest's :func:`plane_section`; where
    its loops lie plainly apart and within the other planes (most caps) they are
    triangulated as they are (:func:`plain_rings_section`, no shapely); else it is
    taken by :func:`loop_section` where the segments chain simply (the same polygons,
    without noding them), failing that by plane_section, and cut by the other planes.
    A ``solid`` cap (a party wall's) is the section with its holes filled
    (:func:`_filled`) between the u coordinates of each span given."""
    a, b, c = plane
    origin = np.array([a * c, b * c, 0.0])
    normal = np.array([a, b, 0.0])
    u = np.array([-b, a, 0.0])                 # horizontal, in the plane
    w = np.array([0.0, 0.0, 1.0])
    bounds = _bounds(plane, planes, origin, u)
    if bounds[0] >= bounds[1]:
        return None                            # the other planes keep nothing of it
    rings = plain_rings_section(mesh_v, mesh_f, labels, origin, normal, u, w)
    if rings is not None:
        if not (np.diff(rings.poly_ends) > 1).any():                # no holes to fill
            solid = None
        if not len(rings.xy) or (solid is None and bounds[0] <= rings.xy[:, 0].min()
                                 and rings.xy[:, 0].max() <= bounds[1]):
            return _triangulated(rings, origin, normal, u, w)
        section = shapely.from_ragged_array(POLYGON, rings.xy,
                                            (rings.ring_ends, rings.poly_ends))
    else:
        section = loop_section(mesh_v, mesh_f, labels, origin, normal, u, w)
        if section is None:
            whole = trimesh.Trimesh(mesh_v, mesh_f, process=False)
            section = plane_section(whole, origin, normal, u, w, labels)
    if solid is not None:
        section = _filled(section, solid)
    if bounds != (-np.inf, np.inf):
        section = shapely.intersection(section, box(max(bounds[0], -1e6), -1e6,
                                                    min(bounds[1], 1e6), 1e6))
    return _triangulated(_rings(section), origin, normal, u, w)


def _filled(section, spans: list[tuple[float, float]]) -> shapely.Geometry:
    """The section with the holes filled that lie mostly (by area) between one of the
    spans' u coordinates, all its polygons joined: a wall with its window recesses
    filled, and the window frames that lay in them gone into it, where the neighbour
    stands; a window mostly past the neighbour's end stays whole, as no half window
    does."""
    parts = shapely.get_parts(section)
    polys = parts[shapely.get_type_id(parts) == POLYGON]
    if any(lo <= -WHOLE and WHOLE <= hi for lo, hi in spans):
        polys = shapely.polygons(shapely.get_exterior_ring(polys))
    else:
        bands = shapely.union_all([box(lo, -1e6, hi, 1e6) for lo, hi in spans])
        polys = np.array([_holes_kept(p, bands) for p in polys], dtype=object)
    # (valid first: a ring that touches itself would stop GEOS's union, and the export)
    return shapely.union_all(shapely.make_valid(polys))


def _holes_kept(poly: shapely.Polygon, bands: shapely.Geometry) -> shapely.Polygon:
    """``poly`` without the holes that lie mostly within ``bands``."""
    if not poly.interiors:
        return poly
    holes = shapely.polygons(list(poly.interiors))
    inside = shapely.area(shapely.intersection(holes, bands))
    keep = inside < shapely.area(holes) / 2
    return shapely.Polygon(poly.exterior, [h for h, k in zip(poly.interiors, keep,
                                                             strict=True) if k])


def _bounds(plane: tuple[float, float, float], planes: tuple[tuple[float, float, float], ...],
            origin: np.ndarray, u: np.ndarray) -> tuple[float, float]:
    """The range of the cap's u coordinate the other planes keep."""
    lo, hi = -np.inf, np.inf
    for a2, b2, c2 in planes:
        if (a2, b2, c2) == plane:
            continue
        k = a2 * u[0] + b2 * u[1]              # (a2, b2) . u
        if abs(k) < 1e-9:
            continue
        limit = (c2 - (a2 * origin[0] + b2 * origin[1])) / k
        lo, hi = (lo, min(hi, limit)) if k > 0 else (max(lo, limit), hi)
    return float(lo), float(hi)


def _rings(section) -> Rings:
    """A shapely section's polygons (more than a speck of area) as :class:`Rings`."""
    parts = shapely.get_parts(section)
    polys = parts[(shapely.get_type_id(parts) == POLYGON) & (shapely.area(parts) > 1e-8)]
    if not len(polys):
        return NO_RINGS
    rings, owner = shapely.get_rings(polys, return_index=True)   # shell, then holes
    xy, at = shapely.get_coordinates(rings, return_index=True)
    return Rings(xy, np.r_[0, np.cumsum(np.bincount(at, minlength=len(rings)))],
                 np.r_[0, np.cumsum(np.bincount(owner, minlength=len(polys)))])


def _triangulated(rings: Rings, origin: np.ndarray, normal: np.ndarray, u: np.ndarray,
                  w: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Polygons more than a speck of area triangulated by earcut on their rings
    (closing points kept, as trimesh passes them), in 3D on the plane, facing along
    ``normal`` (out of the kept side); None when there are none."""
    xy, ring_ends, poly_ends = rings
    if not len(xy):
        return None
    faces = [triangulate_float64(xy[ring_ends[r0]:ring_ends[r1]],
                                 ring_ends[r0 + 1:r1 + 1] - ring_ends[r0]
                                 ).reshape(-1, 3).astype(np.int64) + ring_ends[r0]
             for r0, r1, area in zip(poly_ends[:-1], poly_ends[1:], _areas(rings),
                                     strict=True) if area > 1e-8]
    if not faces:
        return None
    verts = origin + np.outer(xy[:, 0], u) + np.outer(xy[:, 1], w)
    f = np.concatenate(faces)
    e1, e2 = verts[f[:, 1]] - verts[f[:, 0]], verts[f[:, 2]] - verts[f[:, 0]]
    facing = np.stack([e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1],
                       e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2],
                       e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]], axis=1) @ normal
    return verts, np.where((facing < 0)[:, None], f[:, ::-1], f)


def _areas(rings: Rings) -> np.ndarray:
    """Each polygon's area: its shell's (shoelace) less its holes'."""
    xy, ring_ends, poly_ends = rings
    cross = xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]
    cross[ring_ends[1:-1] - 1] = 0.0            # from one ring's last point to the next
    ring = -np.abs(np.add.reduceat(cross, ring_ends[:-1])) / 2   # holes count less
    ring[poly_ends[:-1]] *= -1                                        # shells more
    return np.add.reduceat(ring, poly_ends[:-1])


def _with_caps(out: list[Piece], original: tuple[Piece, ...],
               caps: list[tuple[np.ndarray, np.ndarray]]) -> tuple[Piece, ...]:
    """The caps joined to the walls piece (or, failing one, added as the first piece's
    material)."""
    cv = np.concatenate([v for v, _f in caps])
    offsets = np.concatenate([[0], np.cumsum([len(v) for v, _f in caps])[:-1]])
    cf = np.concatenate([f + o for (_v, f), o in zip(caps, offsets, strict=True)])
    for i, p in enumerate(out):
        if p.name == CAP_PIECE:
            out[i] = Piece(p.name, p.rgba, np.concatenate([p.vertices, cv]),
                           np.concatenate([p.faces, cf + len(p.vertices)]))
            return tuple(out)
    ref = next((p for p in original if p.name == CAP_PIECE), original[0])
    return (*out, Piece(ref.name, ref.rgba, cv, cf))


def load_kernels() -> None:
    """Run the compiled cut kernels (clip, section, face normals, the arrays USD
    writes) once on a box: loads
    them from numba's cache, or compiles them (about 6 s). A local city's parent does
    this before its workers fork, so they inherit them instead of each compiling them."""
    box_ = trimesh.creation.box()
    v, f = np.asarray(box_.vertices, dtype=float), np.asarray(box_.faces, dtype=np.int64)
    piece = Piece("walls", (200, 200, 200, 255), v, f)
    labels = np.zeros(len(f), dtype=np.int64)
    for p in _cut((piece,), 1.0, Cut((0.0, 0.0), ((1.0, 0.0, 0.25),)), labels):
        p.float32_arrays()   # loads the normals and written-arrays kernels
