"""The gallery's close-up sheet of joints (``joints.png``): how facade runs meet, in each
sample style, seen from close by so a crack, a fin or an overlap shows.

Columns are the joint kinds (an acute convex corner, a right one, an obtuse one, a
concave corner, a bend, a T junction), rows the styles; each panel is a three-quarter
view from about 30 m outside the joint, a little above street level, over a small top
view. The inputs are tiny synthetic skeletons (two 40 m legs meeting at the joint, a
bent line, a T) solved like any building, so the sheet shows what a user's building
gets. Angles are chosen off the library's corner angles (90, 120, 135, 150 degrees,
matched within :data:`ANGLE_TOL`) except the right angle, so most corners are mitre
joints; each label says what the solver chose (a library part or a mitre), read from
the layout's key points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import trimesh
from shapely.geometry import LineString

from citysynth.export.assemble import world_mesh
from citysynth.export.layout import Layout
from citysynth.parts_db import PartDB
from citysynth.pipeline.layouts import solve_layouts
from citysynth.skeletons import skeleton_from_lines
from citysynth.skeletons.geojson import Feature, Frame

STYLES = ("classic", "modern")
LEG = 40.0             # metres: each side of a corner, long enough for any corner part
ANGLE_TOL = 2.0        # degrees: a corner takes a library part only this close to its angle
SOLVE: dict[str, Any] = {"stretch": 0.1, "slack": 1.0, "angle_tol": ANGLE_TOL}
CAMERA_Z = 12.0        # metres: a little above street level, where the roofs still show
LOOK_Z = 8.0           # metres: the point looked at above the joint
TOP_HALF = 32.0        # metres: half the side of the top view's square
TILE = (330, 300)      # pixels of one close-up; the top view below it is half as high
FRAME = Frame("local", (0.0, 0.0))


@dataclass(frozen=True)
class Joint:
    """One column of the sheet: a skeleton made of ``lines`` (facades on their right,
    the building mass on their left), the key point at ``at`` to look at, and the
    compass direction (degrees, counter-clockwise from +X) the camera looks from,
    ``swing`` degrees off it (a three-quarter view), ``dist`` metres away."""

    kind: str
    lines: tuple[tuple[tuple[float, float], ...], ...]
    at: tuple[float, float]
    view: float
    swing: float = 20.0
    dist: float = 30.0
    straight_tol: float = 15.0
    props: dict[str, Any] = field(default_factory=dict)


def _corner(kind: str, angle: float, convex: bool, dist: float = 30.0,
            leg: float = LEG) -> Joint:
    """Two ``leg`` m legs meeting at the origin at ``angle`` degrees (inside the mass
    for a convex corner): the first runs along +X, the second turns left (convex) or
    right (concave) by 180 - angle. The camera stands on the bisector of the two facade
    normals, i.e. outside the joint on the street side."""
    turn = math.radians((180.0 - angle) * (1 if convex else -1))
    second = (leg * math.cos(turn), leg * math.sin(turn))
    # facade normals point right of each leg: (0, -1) and (sin t, -cos t)
    bis = (math.sin(turn), -1.0 - math.cos(turn))
    return Joint(kind, (((-leg, 0.0), (0.0, 0.0), second),), (0.0, 0.0),
                 math.degrees(math.atan2(bis[1], bis[0])), dist=dist)


def _bend(turn: float) -> Joint:
    """One facade line bending left by ``turn`` degrees at the origin (a bend: below the
    straightness tolerance, so modules run across it and fold). The sides are of
    unequal, odd lengths so the bend falls inside a module, not between two."""
    t = math.radians(turn)
    j = _corner("bend", 180.0 - turn, True)
    return Joint(f"bend {turn:g}°", (((-37.0, 0.0), (0.0, 0.0),
                                      (41.0 * math.cos(t), 41.0 * math.sin(t))),),
                 (0.0, 0.0), j.view, straight_tol=turn + 5.0)


def _t_junction() -> Joint:
    """A 90 m main line with a 35 m wing off its middle behind the main facade (where T
    parts put it), seen from the yard between the wing and the main line; the yard's
    corners lie a building depth behind the line, so the camera stands further off."""
    return Joint("T junction", (((-45.0, 0.0), (45.0, 0.0)), ((0.0, 0.0), (0.0, 35.0))),
                 (0.0, 0.0), 45.0, swing=-5.0, dist=48.0)


JOINTS = (
    # at 30° the two legs' masses overlap for about 3.7 building depths from the nose
    # (about 50 m): longer legs, so their far ends do not meet each other
    _corner("acute convex 30°", 30.0, True, dist=25.0, leg=75.0),
    _corner("right convex 90°", 90.0, True),
    _corner("obtuse convex 140°", 140.0, True),
    _corner("concave 95°", 95.0, False),
    _bend(20.0),
    _t_junction(),
)


def solve_joint(db: PartDB, joint: Joint, style: str) -> Layout:
    """The best layout of ``joint``'s skeleton in ``style`` (the sample library solves
    every one; a failure is a bug, raised)."""
    feats = [Feature(i, LineString(line), dict(joint.props)) for i, line in enumerate(joint.lines)]
    sk = skeleton_from_lines(feats, FRAME, name=joint.kind, straight_tol=joint.straight_tol)
    built = solve_layouts("joint", [sk], db, style, 1, **SOLVE)
    if built.status != "ok":
        raise RuntimeError(f"gallery joints: {joint.kind}, {style}: {built.reason}")
    return built.layouts[0]


def joint_label(lay: Layout, at: tuple[float, float]) -> str:
    """What the key point at ``at`` got: a library part (its id), or the joint
    treatment placement gave it (``mitre``; ``nose`` for an acute convex corner)."""
    keys = [k for s in lay.structures for k in s["keys"]]
    key = min(keys, key=lambda k: math.dist(k["xy"], at))
    if math.dist(key["xy"], at) > 0.01:      # a bend: no key point, the modules run on
        starts = any(math.dist(i.origin, at) < 0.05 for i in lay.instances)
        return "modules meet at the bend" if starts else "module folded across it"
    how = str(key.get("joint", "part"))
    return f"part {key['part']}" if how == "part" else how


@dataclass
class Panel:
    style: str
    joint: Joint
    mesh: trimesh.Trimesh
    got: str


def joint_panels(db: PartDB) -> list[Panel]:
    """Every (style, joint) panel of the sheet, solved and placed, row by row."""
    out = []
    for style in STYLES:
        for joint in JOINTS:
            lay = solve_joint(db, joint, style)
            out.append(Panel(style, joint, world_mesh(lay, db), joint_label(lay, joint.at)))
    return out


def _camera(joint: Joint) -> list[tuple[float, float, float]]:
    a = math.radians(joint.view + joint.swing)
    x, y = joint.at
    eye = (x + joint.dist * math.cos(a), y + joint.dist * math.sin(a), CAMERA_Z)
    return [eye, (x, y, LOOK_Z), (0.0, 0.0, 1.0)]


def _draw(plotter, panel: Panel, top: bool) -> None:
    import pyvista as pv

    from citysynth.export.preview import to_polydata

    x, y = panel.joint.at
    poly = to_polydata(panel.mesh)
    plotter.set_background("white", top="#dfe8f0")
    plotter.add_mesh(pv.Plane(center=(x, y, -0.05), direction=(0, 0, 1), i_size=400,
                              j_size=400), color="#ecebe6", smooth_shading=False)
    plotter.add_mesh(poly, scalars="rgb", rgb=True, smooth_shading=False)
    plotter.enable_lightkit()
    if top:
        plotter.enable_parallel_projection()
        plotter.camera_position = [(x, y, 200.0), (x, y, 0.0), (0.0, 1.0, 0.0)]
        plotter.camera.parallel_scale = TOP_HALF
        plotter.camera.clipping_range = (1.0, 400.0)
        return
    plotter.camera_position = _camera(panel.joint)
    plotter.camera.view_angle = 50.0
    plotter.camera.clipping_range = (0.5, 600.0)
    # at the foot (over the ground), in pixels: a fixed font size (corner annotations
    # scale with the text length)
    plotter.add_text(f"{panel.style}: {panel.joint.kind}\n{panel.got}", font_size=9,
                     color="black", position=(4, 4))


def render_sheet(panels: list[Panel], out_png: Path) -> Path:
    """The panels in a grid (columns: joints; per style a close-up row over a top-view
    row half as high) to ``out_png``."""
    import pyvista as pv

    from citysynth.parts_db.files import atomic_path

    cols = len(JOINTS)
    rows = 2 * len(STYLES)
    weights = [2, 1] * len(STYLES)
    size = (cols * TILE[0], len(STYLES) * (TILE[1] + TILE[1] // 2))
    plotter = pv.Plotter(off_screen=True, shape=(rows, cols), row_weights=weights,
                         window_size=size, border=True, border_color="#bbbbbb")
    for i, panel in enumerate(panels):
        r, c = divmod(i, cols)
        for top in (False, True):
            plotter.subplot(2 * r + int(top), c)
            _draw(plotter, panel, top)
    with atomic_path(out_png) as tmp:
        plotter.screenshot(str(tmp))
    plotter.close()
    return out_png
