"""The sample part library's generator: real mesh files and a manifest, deterministic.

``python -m citysynth.parts_db.sample [OUT]`` (or ``make library``) writes ``examples/library``:
two facade styles (middle parts of six or more widths with window bays, doors,
balconies, string courses and cornices; end parts; corners of 90 and 135 degrees,
convex and concave; T parts), tower parts (ground floors, floors of varied outlines,
areas and heights, roofs) and complete buildings 6-24 m wide for street fronts. Every
part is built from closed boxes and extrusions in the canonical frame (README), and
windows, doors and balconies are named sub-meshes of each GLB scene, so ingest counts
them from the files.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon

OUT = Path(__file__).resolve().parent.parent / "examples" / "library"  # in the repository


@dataclass(frozen=True)
class Style:
    name: str
    ground_h: float
    storey_h: float
    wall_t: float
    depth: float
    bay_w: float
    win_w: float
    win_h: float
    sill: float
    cornice: tuple[tuple[float, float], ...]   # (protrusion, height) steps, bottom up
    ledge: float
    pitched: bool
    wall: tuple[int, int, int]
    trim: tuple[int, int, int]


CLASSIC = Style("classic", 4.2, 3.4, 0.5, 11.0, 2.6, 1.2, 1.9, 0.9,
                ((0.25, 0.25), (0.5, 0.3), (0.7, 0.2)), 0.12, True,
                (221, 205, 170), (245, 240, 228))
MODERN = Style("modern", 4.0, 3.1, 0.35, 12.0, 3.2, 2.4, 2.1, 0.6,
               ((0.15, 0.9),), 0.0, False, (168, 172, 176), (60, 62, 66))
GLASS = (70, 95, 120)
ROOF = (120, 70, 60)


def _rect(x0, x1, y0, y1) -> Polygon:
    """The axis-aligned rectangle x0..x1 by y0..y1 (argument order as in _box)."""
    return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])


def _box(x0, x1, y0, y1, z0, z1, color):
    m = trimesh.creation.box(extents=[x1 - x0, y1 - y0, z1 - z0])
    m.apply_translation([(x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2])
    m.visual.face_colors = [*color, 255]
    return m


def _prism(poly: Polygon, z0: float, z1: float, color):
    m = trimesh.creation.extrude_polygon(shapely.normalize(poly), z1 - z0)
    m.apply_translation([0, 0, z0])
    m.visual.face_colors = [*color, 255]
    return m


def _along_x(profile: Polygon, x0: float, x1: float, color):
    """A profile drawn in (y, z) extruded along X from x0 to x1."""
    m = trimesh.creation.extrude_polygon(shapely.normalize(profile), x1 - x0)
    rot = np.eye(4)
    rot[:3, :3] = [[0, 0, 1], [1, 0, 0], [0, 1, 0]]
    m.apply_transform(rot)
    m.apply_translation([x0, 0, 0])
    m.visual.face_colors = [*color, 255]
    return m


class Parts:
    """Named sub-meshes of one part; the names become the GLB scene's nodes."""

    def __init__(self):
        self.items: list[tuple[str, trimesh.Trimesh]] = []
        self.counts = {"window": 0, "door": 0, "balcony": 0}

    def add(self, kind: str, mesh) -> None:
        if kind in self.counts:
            name = f"{kind}_{self.counts[kind]:03d}"
            self.counts[kind] += 1
        else:
            name = f"{kind}_{len(self.items):03d}"
        self.items.append((name, mesh))

    def transform(self, matrix) -> None:
        for _, m in self.items:
            m.apply_transform(matrix)

    def extend(self, other: Parts) -> None:
        for name, m in other.items:
            kind = name.rsplit("_", 1)[0]
            self.add(kind, m)

    def glb(self) -> bytes:
        scene = trimesh.Scene()
        walls = [m for n, m in self.items if n.startswith("wall")]
        if walls:
            scene.add_geometry(trimesh.util.concatenate(walls), node_name="walls",
                               geom_name="walls")
        for name, m in self.items:
            if not name.startswith("wall"):
                scene.add_geometry(m, node_name=name, geom_name=name)
        return scene.export(file_type="glb")


def storey_levels(style: Style, storeys: int) -> list[tuple[float, float]]:
    zs = [(0.0, style.ground_h)]
    for _ in range(storeys - 1):
        z = zs[-1][1]
        zs.append((z, z + style.storey_h))
    return zs


def facade_chunk(style: Style, x0: float, x1: float, storeys: int, *, door: int | None,
                 balconies: set[int], roof: bool = True) -> Parts:
    """A building chunk from x0 to x1: body, a front wall with real window and door
    openings between piers, glass, string courses, balconies, cornice and roof."""
    P = Parts()
    s, t, D = style, style.wall_t, style.depth
    levels = storey_levels(s, storeys)
    H = levels[-1][1]
    P.add("wall", _box(x0, x1, t, D, 0, H, s.wall))
    nb = max(1, round((x1 - x0) / s.bay_w))
    bw = (x1 - x0) / nb
    ww = min(s.win_w, bw - 0.9)
    for b in range(nb):
        bx0 = x0 + b * bw
        wx0, wx1 = bx0 + (bw - ww) / 2, bx0 + (bw + ww) / 2
        P.add("wall", _box(bx0, wx0, 0, t, 0, H, s.wall))
        P.add("wall", _box(wx1, bx0 + bw, 0, t, 0, H, s.wall))
        for k, (z0, z1) in enumerate(levels):
            if k == 0 and b == door:
                top = min(z0 + 2.6, z1 - 0.4)
                P.add("wall", _box(wx0, wx1, 0, t, top, z1, s.wall))
                P.add("door", _box(wx0, wx1, t * 0.6, t * 0.8, z0, top, s.trim))
                continue
            sill, head = z0 + s.sill, min(z0 + s.sill + s.win_h, z1 - 0.3)
            P.add("wall", _box(wx0, wx1, 0, t, z0, sill, s.wall))
            P.add("wall", _box(wx0, wx1, 0, t, head, z1, s.wall))
            P.add("window", _box(wx0, wx1, t * 0.55, t * 0.65, sill, head, GLASS))
            if s.ledge:
                P.add("wall", _box(wx0 - 0.1, wx1 + 0.1, -0.08, 0, sill - 0.08, sill, s.trim))
            if k in balconies and k > 0:
                bal = trimesh.util.concatenate([
                    _box(wx0 - 0.25, wx1 + 0.25, -1.3, 0, z0, z0 + 0.18, s.trim),
                    _box(wx0 - 0.25, wx1 + 0.25, -1.3, -1.22, z0 + 0.18, z0 + 1.1, s.trim),
                    _box(wx0 - 0.25, wx0 - 0.17, -1.3, 0, z0 + 0.18, z0 + 1.1, s.trim),
                    _box(wx1 + 0.17, wx1 + 0.25, -1.3, 0, z0 + 0.18, z0 + 1.1, s.trim)])
                P.add("balcony", bal)
    if s.ledge:
        for z0, _ in levels[1:]:
            P.add("wall", _box(x0, x1, -s.ledge, 0, z0 - 0.2, z0, s.trim))
    z = H
    for prot, h in s.cornice:  # stepped cornice
        P.add("wall", _box(x0, x1, -prot, t, z, z + h, s.trim))
        z += h
    if roof and s.pitched:
        ridge = Polygon([(t, z), (D, z), (D, z + 0.2), ((t + D) / 2, z + 3.2), (t, z + 0.2)])
        P.add("wall", _along_x(ridge, x0, x1, ROOF))
    elif roof:  # a parapet at the back, as high as the front cornice
        P.add("wall", _box(x0, x1, D - 0.3, D, H, z, s.wall))
    return P


def _rot(angle_deg: float):
    return trimesh.transformations.rotation_matrix(math.radians(angle_deg), [0, 0, 1])


def corner(style: Style, angle: float, convex: bool, storeys: int) -> Parts:
    """In-leg along -X, out-leg turned left (convex) or right (concave) by 180 - angle."""
    leg = style.depth + 2 * style.bay_w
    turn = (180.0 - angle) * (1 if convex else -1)
    P = facade_chunk(style, -leg, 0.0, storeys, door=None, balconies=set())
    arm = facade_chunk(style, 0.0, leg, storeys, door=None, balconies=set())
    arm.transform(_rot(turn))
    P.extend(arm)
    H = storey_levels(style, storeys)[-1][1]
    if not convex:  # fill the wedge on the building side between the two arms
        far = np.array([0.0, style.depth])
        c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
        wedge = Polygon([(0, 0), tuple(far), (c * far[0] - s * far[1], s * far[0] + c * far[1])])
        P.add("wall", _prism(wedge.buffer(0.01, join_style=2), 0, H, style.wall))
    return P


def t_junction(style: Style, storeys: int) -> Parts:
    """Main chunk along X through the origin, a wing along +Y behind it (its facade
    facing +X, its mass on the -X side, like any leg's)."""
    leg = style.depth + 2 * style.bay_w
    P = facade_chunk(style, -leg, leg, storeys, door=None, balconies=set())
    wing = facade_chunk(style, 0.0, leg, storeys, door=None, balconies=set())
    wing.transform(_rot(90.0))
    P.extend(wing)
    return P


def end_part(style: Style, storeys: int, left: bool) -> Parts:
    w = 2 * style.bay_w
    P = facade_chunk(style, 0.0, w, storeys, door=None, balconies=set())
    H = storey_levels(style, storeys)[-1][1]
    x = 0.0 if left else w - 0.45
    P.add("wall", _box(x, x + 0.45, -0.25, style.depth, 0, H, style.trim))  # gable quoin
    return P


FOOTPRINTS = {
    "square18": _rect(-9, 9, -9, 9),
    "rect22x16": _rect(-11, 11, -8, 8),
    "octagon20": Polygon([(-10, -4), (-4, -10), (4, -10), (10, -4), (10, 4), (4, 10),
                          (-4, 10), (-10, 4)]),
    "cross20": _rect(-10, 10, -5, 5).union(_rect(-5, 5, -10, 10)),
    "round16": Polygon([(10 * math.cos(a), 10 * math.sin(a))
                        for a in np.linspace(0, 2 * math.pi, 17)[:-1]]),
    "lshape": _rect(-10, 10, -10, 0).union(_rect(-10, 0, 0, 10)),
    "hexagon": Polygon([(10 * math.cos(a), 10 * math.sin(a))
                        for a in np.linspace(0, 2 * math.pi, 7)[:-1]]),
    "square14": _rect(-7, 7, -7, 7),
    "chamfer16": Polygon([(-8, -6), (-6, -8), (6, -8), (8, -6), (8, 6), (6, 8), (-6, 8),
                          (-8, 6)]),
    "rect12x18": _rect(-6, 6, -9, 9),
    "slim10": _rect(-5, 5, -7, 7),
}


def floor_part(fp: Polygon, h: float, color) -> Parts:
    P = Parts()
    P.add("wall", _prism(fp, 0, 0.3, (200, 200, 196)))
    P.add("window", _prism(fp.buffer(-0.4, join_style=2), 0.3, h, GLASS))
    for x, y in list(fp.exterior.coords)[:-1]:
        col = _rect(x - 0.25, x + 0.25, y - 0.25, y + 0.25).intersection(fp)
        if not col.is_empty and col.area > 0.01:
            P.add("wall", _prism(col, 0.3, h, color))
    return P


def ground_floor(fp: Polygon, h: float) -> Parts:
    P = floor_part(fp, h, (90, 90, 95))
    P.add("wall", _prism(fp.buffer(1.2, join_style=2), 0, 0.25, (150, 150, 150)))
    minx, miny, maxx, _ = fp.bounds
    cx = (minx + maxx) / 2
    P.add("door", _box(cx - 1.5, cx + 1.5, miny - 0.1, miny + 0.2, 0.25, 3.0, (40, 40, 40)))
    return P


def roof(fp: Polygon, kind: int) -> Parts:
    P = Parts()
    P.add("wall", _prism(fp, 0, 0.5, (180, 180, 175)))
    ring = fp.difference(fp.buffer(-0.35, join_style=2))
    P.add("wall", _prism(ring, 0.5, 1.6, (150, 150, 150)))
    core = fp.buffer(-3.5, join_style=2)
    if not core.is_empty:
        top = 3.0 + kind
        P.add("wall", _prism(core.minimum_rotated_rectangle.buffer(-1, join_style=2)
                             if kind else core, 0.5, top, (120, 120, 125)))
    return P


def generate(out: Path = OUT) -> list[dict]:
    """Write the meshes and manifest.toml into ``out``; returns the manifest entries."""
    mesh_dir = out / "meshes"
    mesh_dir.mkdir(parents=True, exist_ok=True)
    entries: list[dict] = []

    def write(pid: str, P: Parts, **meta) -> None:
        (mesh_dir / f"{pid}.glb").write_bytes(P.glb())
        entries.append({"id": pid, "file": f"meshes/{pid}.glb", **meta})

    for style, widths, storeys in ((CLASSIC, (2.6, 3.8, 5.2, 6.4, 7.8, 9.0, 10.4), (4, 5)),
                                   (MODERN, (3.2, 4.4, 6.4, 7.6, 9.6, 12.8), (5, 6))):
        for i, w in enumerate(widths):
            for st in storeys:
                bays = max(1, round(w / style.bay_w))
                door = (bays // 2) if i % 2 == 0 else None
                balc = {2, 3} if (i + st) % 3 == 0 else set()
                write(f"{style.name}_mid_{w:.1f}_{st}s", facade_chunk(
                    style, 0.0, w, st, door=door, balconies=balc),
                    cls="middle", style=style.name, length=w)
        st = storeys[0]
        write(f"{style.name}_end_left", end_part(style, st, True), cls="end_left",
              style=style.name)
        write(f"{style.name}_end_right", end_part(style, st, False), cls="end_right",
              style=style.name)
        for angle in (90, 135):
            for convex in (True, False):
                kind = "convex" if convex else "concave"
                write(f"{style.name}_corner_{angle}_{kind}", corner(style, angle, convex, st),
                      cls="corner", style=style.name, angle=angle, convex=convex)
        write(f"{style.name}_t", t_junction(style, st), cls="t_junction", style=style.name)

    names = list(FOOTPRINTS)
    for i, name in enumerate(names[:3]):
        write(f"tower_ground_{name}", ground_floor(FOOTPRINTS[name], 4.6 + 0.2 * i),
              cls="ground_floor", style="tower")
    heights = (3.0, 3.2, 3.4, 3.6, 3.8, 4.0, 4.2, 4.4, 4.6, 4.8, 5.0)
    for name, h in zip(names, heights, strict=True):
        write(f"tower_floor_{name}_{h:.1f}", floor_part(FOOTPRINTS[name], h, (110, 115, 120)),
              cls="floor", style="tower")
    for i, name in enumerate(("square18", "octagon20", "square14")):
        write(f"tower_roof_{name}", roof(FOOTPRINTS[name], i % 2), cls="roof", style="tower")

    rng = np.random.default_rng(2024)
    widths = np.sort(rng.choice(np.arange(30, 121), size=72, replace=False)) * 0.2
    for i, w in enumerate(widths):
        style = CLASSIC if i % 2 == 0 else MODERN
        st = int(rng.integers(2, 8))
        bays = max(1, round(w / style.bay_w))
        balc = set(rng.choice(np.arange(1, st), size=min(st - 1, int(rng.integers(0, 3))),
                              replace=False).tolist()) if st > 1 else set()
        P = facade_chunk(style, 0.0, float(w), st, door=int(rng.integers(0, bays)),
                         balconies=balc, roof=bool(rng.integers(0, 4)))
        write(f"bldg_{i:02d}_{w:.1f}m_{style.name}_{st}s", P, cls="building",
              style=style.name, length=round(float(w), 1))

    lines = ["# The citysynth sample library, written by parts_db/sample.py (make library).",
             "# Canonical frame: +X along the primary dimension, facade toward -Y, +Z up.",
             "", "[library]", 'name = "citysynth sample"', "quantum = 0.2", 'units = "m"',
             ""]
    for e in entries:
        lines.append("[[part]]")
        lines.append(f'id = "{e["id"]}"')
        lines.append(f'file = "{e["file"]}"')
        lines.append(f'class = "{e["cls"]}"')
        lines.append(f'style = "{e["style"]}"')
        if "angle" in e:
            lines.append(f"angle = {e['angle']}")
            lines.append(f"convex = {str(e['convex']).lower()}")
        if "length" in e:
            lines.append(f"length = {e['length']}")
        lines.append("")
    (out / "manifest.toml").write_text("\n".join(lines), encoding="utf-8")
    return entries


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    n = len(generate(target))
    print(f"wrote {n} parts to {target}")
