"""Closed solids for the sample library, assembled face by face.

The sample parts are built the way a modeller builds clean assets: every body is one
closed, consistently wound surface with no internal or doubled faces, so a renderer never
sees two coplanar faces fight and a section cut is one loop per body. A :class:`Solid`
collects planar polygons (with holes) and shares their vertices by position, so faces
built separately close up exactly when their boundaries agree vertex for vertex; a
polygon may carry extra vertices along its edges for that (a T-junction is a crack). Each
face keeps its material (walls, roof, trim ...), and :class:`PartMesh` writes one GLB
node per material plus one named node per window, door and balcony, which ingest counts.

Polygons are triangulated with GEOS's constrained Delaunay triangulation, which keeps
every input vertex (earcut drops collinear ones, which would reopen those cracks).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from typing import cast

import numpy as np
import shapely
import trimesh

Vec = np.ndarray
DIGITS = 6          # vertices are shared when equal to a micrometre
# faces of the main bodies, in GLB order; a family's own colours are "walls_b", "roof_b" ...
MATERIALS = ("walls", "trim", "roof")
ITEMS = ("window", "door", "balcony")          # counted sub-meshes, one node each


def unit(v) -> Vec:
    v = np.asarray(v, dtype=float)
    return v / math.sqrt(float(v @ v))


def cross(a, b) -> Vec:
    """np.cross for two 3-vectors, without its generality (it is called very often)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def _plane_axes(normal: Vec) -> tuple[Vec, Vec]:
    """Two unit axes spanning the plane with this normal (right-handed with it)."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    a = unit(cross(helper, normal))
    return a, cross(normal, a)


def _dedupe(points: Sequence[Vec]) -> list[Vec]:
    """Drop consecutive repeats (a zero-length edge), including last == first."""
    out: list[Vec] = []
    for p in points:
        if not out or float(np.abs(p - out[-1]).max()) > 10 ** -DIGITS:
            out.append(np.asarray(p, dtype=float))
    while len(out) > 1 and float(np.abs(out[0] - out[-1]).max()) <= 10 ** -DIGITS:
        out.pop()
    return out


class Solid:
    """One body: triangles (kept as arrays until the end), each with a material; their
    vertices are shared by position (to a micrometre) when the mesh is read out."""

    def __init__(self) -> None:
        self._cache: dict[str, tuple[np.ndarray, np.ndarray]] | None = None
        self._tris: list[np.ndarray] = []       # [k, 3, 3] per batch
        self._normals: list[Vec] = []           # the side each batch faces
        self._mats: list[str] = []              # one material per batch

    @property
    def materials(self) -> set[str]:
        return set(self._mats)

    def polygon(self, outer: Sequence, normal, material: str,
                holes: Iterable[Sequence] = ()) -> None:
        """A planar polygon (3D points, any winding) facing ``normal``, minus holes."""
        n = unit(normal)
        ring = _dedupe([np.asarray(p, dtype=float) for p in outer])
        hole_rings = [_dedupe([np.asarray(p, dtype=float) for p in h]) for h in holes]
        if len(ring) < 3:
            return
        if not hole_rings and len(ring) <= 4 and _convex(ring, n):
            self._fan(ring, n, material)
        else:
            self._triangles(_triangulate(ring, hole_rings, n), n, material)

    def quad(self, corners: Sequence, normal, material: str) -> None:
        """A convex quadrilateral (the caller knows it is), facing ``normal``."""
        self._fan([np.asarray(p, dtype=float) for p in corners], unit(normal), material)

    def _fan(self, ring: list[Vec], n: Vec, material: str) -> None:
        pts = np.array(ring)
        idx = _FANS[len(pts)]
        self._triangles(pts[idx], n, material)

    def _triangles(self, tris: np.ndarray, n: Vec, material: str) -> None:
        """Triangles [k, 3, 3] to be wound to face ``n`` (done for all at once, when
        the mesh is read out)."""
        if len(tris):
            self._cache = None
            self._tris.append(tris)
            self._normals.append(n)
            self._mats.append(material)

    def box(self, corner, axes: Sequence, sizes: Sequence[float], material: str) -> None:
        """A box from ``corner`` along three orthogonal unit ``axes`` (right-handed or
        not) by ``sizes``."""
        o = np.asarray(corner, dtype=float)
        ax = [unit(a) * s for a, s in zip(axes, sizes, strict=True)]
        centre = o + (ax[0] + ax[1] + ax[2]) / 2
        for k in range(3):
            a, b = ax[(k + 1) % 3], ax[(k + 2) % 3]
            for base in (o, o + ax[k]):
                quad = [base, base + a, base + a + b, base + b]
                mid = base + (a + b) / 2
                self.quad(quad, mid - centre, material)

    def meshes(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Per material: (vertices, faces) of this body's triangles of that material,
        vertices shared by position."""
        if self._cache is None:
            self._cache = self._read_out()
        return self._cache

    def _read_out(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        if not self._tris:
            return {}
        tris = np.concatenate(self._tris)
        counts = [len(t) for t in self._tris]
        mats = np.repeat(np.array(self._mats), counts)
        want = np.repeat(np.array(self._normals), counts, axis=0)
        nt = _cross_rows(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        keep = np.einsum("ij,ij->i", nt, nt) >= 1e-20
        flip = np.einsum("ij,ij->i", nt, want) < 0
        tris[flip] = tris[flip][:, [0, 2, 1]]
        tris, mats = tris[keep], mats[keep]
        pts = np.round(tris.reshape(-1, 3), DIGITS) + 0.0
        verts, inverse = np.unique(pts, axis=0, return_inverse=True)
        faces = inverse.reshape(-1, 3)
        ok = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & \
            (faces[:, 0] != faces[:, 2])
        out = {}
        for m in sorted(set(self._mats)):
            f = faces[ok & (mats == m)]
            used, inv = np.unique(f, return_inverse=True)
            out[m] = (verts[used], inv.reshape(-1, 3))
        return out


_FANS = {k: np.array([[0, i, i + 1] for i in range(1, k - 1)]) for k in (3, 4)}


def _cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


_NEXT = {k: np.r_[1:k, 0] for k in (3, 4)}


def _convex(ring: list[Vec], n: Vec) -> bool:
    pts = np.array(ring)
    nxt = _NEXT[len(pts)]
    edges = pts[nxt] - pts
    return bool((_cross_rows(edges, edges[nxt]) @ n > 1e-12).all())


def _triangulate(ring: list[Vec], holes: list[list[Vec]], n: Vec) -> np.ndarray:
    """Constrained Delaunay triangles [k, 3, 3] of a planar polygon with holes, every
    input vertex kept, as 3D points taken from the input (never recomputed)."""
    a, b = _plane_axes(n)
    rings = [np.array(ring)] + [np.array(h) for h in holes if len(h) >= 3]
    pts3 = np.concatenate(rings)
    flat = np.stack([pts3 @ a, pts3 @ b], axis=1)
    lookup = {(float(x), float(y)): i for i, (x, y) in enumerate(flat.tolist())}
    splits = np.cumsum([len(r) for r in rings])[:-1]
    parts = np.split(flat, splits)
    poly = shapely.Polygon(parts[0], parts[1:])
    coords = shapely.get_coordinates(shapely.constrained_delaunay_triangles(poly))
    idx = np.array([lookup[(x, y)] for x, y in coords.tolist()], dtype=np.int64)
    return pts3[idx.reshape(-1, 4)[:, :3]]


# --- parts: bodies and counted sub-meshes ------------------------------------------------

class PartMesh:
    """One part: its main bodies (faces by material) and its windows, doors and
    balconies, each a body of its own that becomes a named GLB node."""

    def __init__(self, palette: dict[str, tuple[int, int, int]]) -> None:
        self.palette = palette
        self.solids: list[Solid] = []
        self.items: list[tuple[str, Solid | tuple[str, np.ndarray]]] = []
        self.templates: dict[str, Solid] = {}

    def solid(self) -> Solid:
        s = Solid()
        self.solids.append(s)
        return s

    def item(self, kind: str) -> Solid:
        if kind not in ITEMS:
            raise ValueError(f"unknown item kind {kind!r}")
        s = Solid()
        self.items.append((kind, s))
        return s

    def placed(self, kind: str, centre, along, up, sizes: Sequence[float]) -> None:
        """A box-shaped item (a pane, a door leaf) of ``sizes`` along ``along``, ``up``
        and their normal, centred at ``centre``: one unit box per kind is stored and
        each item is a node placing it, so a part with a hundred windows stays small."""
        a, u = unit(along), unit(up)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2] = a * sizes[0], u * sizes[1], cross(a, u) * sizes[2]
        m[:3, 3] = np.asarray(centre, dtype=float)
        self.instance(kind, f"{kind}_box", m, _unit_box)

    def instance(self, kind: str, key: str, matrix: np.ndarray,
                 template: Callable[[], Solid]) -> None:
        """An item that is the shared body ``key`` (made by ``template`` the first time)
        placed by ``matrix`` (rotation, translation and a positive scale per axis)."""
        if kind not in ITEMS:
            raise ValueError(f"unknown item kind {kind!r}")
        if key not in self.templates:
            self.templates[key] = template()
        self.items.append((kind, (key, np.round(matrix, DIGITS) + 0.0)))

    def counts(self) -> dict[str, int]:
        return {k: sum(1 for kind, _s in self.items if kind == k) for k in ITEMS}

    def glb(self) -> bytes:
        scene = trimesh.Scene()
        present = sorted({m for s in self.solids for m in s.materials},
                         key=lambda m: (MATERIALS.index(m.split("_")[0]), m))
        for material in present:
            parts = [s.meshes().get(material) for s in self.solids]
            got = [p for p in parts if p is not None]
            if got:
                scene.add_geometry(_coloured(got, self.palette[material]),
                                   node_name=material, geom_name=material)
        seen = dict.fromkeys(ITEMS, 0)
        for kind, s in self.items:
            name = f"{kind}_{seen[kind]:03d}"
            seen[kind] += 1
            if isinstance(s, Solid):
                (mesh,) = s.meshes().values()
                scene.add_geometry(_coloured([mesh], self.palette[kind]), node_name=name,
                                   geom_name=name)
                continue
            key, matrix = s
            if key in scene.geometry:
                scene.graph.update(frame_from=scene.graph.base_frame, frame_to=name,
                                   matrix=matrix, geometry=key)
            else:
                (mesh,) = self.templates[key].meshes().values()
                scene.add_geometry(_coloured([mesh], self.palette[kind]), node_name=name,
                                   geom_name=key, transform=matrix)
        return scene.export(file_type="glb")

    def trimesh(self) -> trimesh.Trimesh:
        """All bodies as one mesh (for checks and previews), colours per face."""
        parts = []
        for body in self.solids:
            for material, mesh in body.meshes().items():
                parts.append(_coloured([mesh], self.palette[material]))
        for kind, item in self.items:
            if isinstance(item, Solid):
                parts.extend(_coloured([m], self.palette[kind]) for m in item.meshes().values())
            else:
                key, matrix = item
                (mesh,) = self.templates[key].meshes().values()
                placed = _coloured([mesh], self.palette[kind])
                placed.apply_transform(matrix)
                parts.append(placed)
        return cast(trimesh.Trimesh, trimesh.util.concatenate(parts))


def _unit_box() -> Solid:
    s = Solid()
    s.box([-0.5, -0.5, -0.5], list(np.eye(3)), (1.0, 1.0, 1.0), "item")
    return s


def _coloured(meshes: list[tuple[np.ndarray, np.ndarray]], rgb) -> trimesh.Trimesh:
    verts, faces, offset = [], [], 0
    for v, f in meshes:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    v = np.vstack(verts)
    colours = np.tile(np.array([*rgb, 255], dtype=np.uint8), (len(v), 1))
    return trimesh.Trimesh(v, np.vstack(faces), vertex_colors=colours, process=False)
