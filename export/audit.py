"""A 3D audit of what an artist sees: a written layout USD measured in world space.

The layout checks (:mod:`citysynth.export.place`) prove the parts sit right along the
skeleton line; this module measures the assembled geometry itself, composed by usd-core
with every instance resolved to world space, the way a DCC shows it:

- **overlap**: footprint area shared by two different part instances (walls inside
  walls, doubled roofs), against the whole footprint;
- **beyond**: how far any geometry reaches past the outline, on the street side of the
  facade lines (the fins of a badly mitred acute corner stick out into the street). A
  closed ring facing out (a block) owns everything inside it, so a deep part reaching
  into the courtyard is not beyond; elsewhere the mass may reach ``reach`` metres behind
  the facade line;
- **band gaps**: the part of the roof band (the outline inset by the building depth)
  that no instance covers (open V gaps at corners, holes);
- **coplanar roofs**: the area where two upward faces lie in one plane and overlap
  (z-fighting roofs), between instances or inside one.

The outline comes from the layout JSON: each stage's polyline and the side its facades
face (the mass lies on the other side, as deep as the parts are).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
from pxr import Usd, UsdGeom
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from citysynth.export.ground import GRID, footprint, triangle_normals
from citysynth.export.joints import behind
from citysynth.export.naming import INFILL
from citysynth.export.rings import closed_ring, nose_tips, rings_inside

ROOF_NZ = 0.2          # faces whose normal's z exceeds this are roof-like (looked at from above)
PLANE_DIGITS = 3       # planes are the same to the millimetre (and 0.001 in normal)


@dataclass(frozen=True)
class AuditFigures:
    """What the audit measured for one layout (areas in m², lengths in m)."""

    footprint: float
    overlap: float
    beyond_max: float
    band: float
    band_gap: float
    coplanar_roof: float

    @property
    def overlap_share(self) -> float:
        return self.overlap / self.footprint if self.footprint else 0.0

    @property
    def gap_share(self) -> float:
        return self.band_gap / self.band if self.band else 0.0

    def line(self) -> str:
        return (f"overlap {100 * self.overlap_share:.2f} % ({self.overlap:.1f} m²), "
                f"beyond {self.beyond_max:.2f} m, band gaps {100 * self.gap_share:.2f} % "
                f"({self.band_gap:.1f} m²), coplanar roofs {self.coplanar_roof:.2f} m²")


def instance_triangles(usd_path: str | Path) -> dict[str, np.ndarray]:
    """Every instance's triangles in world space, [m, 3, 3] per instanceable prim path
    (meshes that are not under an instance are keyed by their own path)."""
    stage = Usd.Stage.Open(str(usd_path))
    cache = UsdGeom.XformCache()
    out: dict[str, list[np.ndarray]] = defaultdict(list)
    for prim in stage.Traverse(Usd.TraverseInstanceProxies()):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        owner = prim
        while owner and not owner.IsInstance():
            owner = owner.GetParent()
        key = str((owner or prim).GetPath())
        mesh = UsdGeom.Mesh(prim)
        pts = np.asarray(mesh.GetPointsAttr().Get(), dtype=float)
        counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get(), dtype=int)
        index = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), dtype=int)
        m = np.asarray(cache.GetLocalToWorldTransform(prim), dtype=float)
        world = np.c_[pts, np.ones(len(pts))] @ m   # USD: row vectors
        out[key].append(world[:, :3][_fan(counts, index)])
    return {k: np.concatenate(v) for k, v in out.items()}


def _fan(counts: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Polygon faces as triangle fans: [t, 3] vertex indices."""
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    tris = [index[[s, s + i, s + i + 1]] for s, c in zip(starts, counts, strict=True)
            for i in range(1, c - 1)]
    return np.array(tris, dtype=int).reshape(-1, 3)


def outline_regions(structures: list[dict], depth: float) -> BaseGeometry:
    """The ground behind the facade lines, ``depth`` deep: per stage and per pair of
    stages meeting at a key point (so corners are mitred, convex or concave). A closed
    ring facing out keeps only what lies inside it (a single-sided mitred buffer of a
    very acute corner also grows a spike on the street side) and outside its
    courtyards; a courtyard's ring (facing in) only what lies inside the ring round it
    (a wing narrower than two depths is that wide, not two depths)."""
    pieces = []
    rings = [closed_ring(st) for st in structures]
    owners = [r for r, owns in rings if r is not None and owns]
    yards = [r for r, owns in rings if r is not None and not owns]
    for st, (ring, owns) in zip(structures, rings, strict=True):
        regions = shapely.union_all(_stage_regions(st["stages"], depth))
        if ring is not None and owns:   # its courtyards are open ground
            regions = regions.intersection(ring).difference(
                shapely.union_all([y for y in yards if ring.contains(y)]))
        elif ring is not None:   # a courtyard: its mass stops at the outline round it
            round_it = [o for o in owners if o.contains(ring)]
            regions = regions.intersection(shapely.union_all(round_it)) if round_it \
                else regions
        tips = nose_tips(st)
        pieces.append(regions.difference(shapely.union_all(tips)) if tips else regions)
    return shapely.union_all(pieces)


def _stage_regions(stages: list[dict], depth: float) -> list[BaseGeometry]:
    lines = [(s["polyline"], s["front"]) for s in stages]
    ins = {s["to"]: s for s in stages}
    for s in stages:
        prev = ins.get(s["from"])
        if prev is not None and prev["front"] == s["front"]:
            lines.append((prev["polyline"][-2:] + s["polyline"][1:2], s["front"]))
    return [behind(pts, front, depth) for pts, front in lines]


def audit_usd(usd_path: str | Path, structures: list[dict], depth: float,
              reach: float | None = None) -> AuditFigures:
    """Audit the layout USD at ``usd_path`` against its layout's ``structures`` (the
    layout JSON's list). ``depth`` is the building depth the roof band is measured to;
    ``reach`` how deep the mass may go before geometry counts as beyond the outline
    (default: depth + 1 m)."""
    tris = instance_triangles(usd_path)
    feet = {k: footprint(t) for k, t in tris.items()}
    union = shapely.union_all(list(feet.values()), grid_size=GRID)
    parts = [f for k, f in feet.items() if f"/{INFILL}" not in k]   # not a roof infill
    band = outline_regions(structures, depth)
    allowed = shapely.union_all([outline_regions(structures, reach if reach is not None
                                                 else depth + 1.0),
                                 *rings_inside(structures)])
    verts = np.concatenate([t.reshape(-1, 3) for t in tris.values()]) if tris else \
        np.zeros((0, 3))
    beyond = float(np.max(shapely.distance(allowed, shapely.points(verts[:, :2])),
                          initial=0.0))
    return AuditFigures(
        footprint=float(union.area), overlap=_overlap(parts),
        beyond_max=beyond, band=float(band.area),
        band_gap=float(band.difference(union, grid_size=GRID).area),
        coplanar_roof=_coplanar_roofs(tris))


def _overlap(feet: list[BaseGeometry]) -> float:
    """Footprint area shared by pairs of different instances (each pair once)."""
    tree = shapely.STRtree(feet)
    total = 0.0
    for i, f in enumerate(feet):
        for j in tree.query(f):
            if j > i:
                total += float(f.intersection(feet[j], grid_size=GRID).area)
    return total


def _coplanar_roofs(tris: dict[str, np.ndarray]) -> float:
    """Area where upward faces in one plane overlap: between instances, or faces of one
    instance lying over each other."""
    groups: dict[tuple, dict[str, list[np.ndarray]]] = defaultdict(lambda: defaultdict(list))
    for key, t in tris.items():
        n, ok = triangle_normals(t)
        up = ok & (n[:, 2] > ROOF_NZ)
        for tri, nn in zip(t[up], n[up], strict=True):
            plane = (*np.round(nn, PLANE_DIGITS), round(float(nn @ tri[0]), PLANE_DIGITS))
            groups[plane][key].append(tri)
    total = 0.0
    for plane, per_inst in groups.items():
        if sum(len(v) for v in per_inst.values()) < 2:
            continue
        basis = _plane_basis(np.array(plane[:3], dtype=float))
        unions, areas = [], 0.0
        for faces in per_inst.values():
            polys = [Polygon(np.asarray(f) @ basis.T) for f in faces]
            polys = [p for p in polys if p.area > 1e-9]
            areas += sum(p.area for p in polys)
            unions.append(shapely.union_all(polys, grid_size=GRID))
        total += max(areas - float(shapely.union_all(unions, grid_size=GRID).area), 0.0)
    return total


def _plane_basis(n: np.ndarray) -> np.ndarray:
    """Two orthonormal vectors spanning the plane with normal n (rows)."""
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(n, u)])
