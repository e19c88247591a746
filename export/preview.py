"""PNG previews rendered off screen with pyvista.

The contact sheet of a part library (every part, coloured as authored, from a
three-quarter view with soft lighting), and layout previews: a building or block from
a three-quarter view beside a top view, on a pale ground plane, sized for a README
(1400 x 700 by default). Rendering uses VTK's EGL (or OSMesa) off-screen window, no
display needed.
"""

from __future__ import annotations

import math
import threading
from pathlib import Path

import numpy as np
import pyvista as pv
import trimesh
import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (vtkRenderWindow() is then its EGL window)
from vtkmodules.vtkCommonCore import vtkLogger
from vtkmodules.vtkRenderingCore import vtkRenderer, vtkRenderWindow

from citysynth.parts_db import PartDB
from citysynth.parts_db.files import atomic_path

pv.OFF_SCREEN = True
# VTK tries an X display before falling back to EGL and warns on stderr when there is
# none; headless is the normal case here, so keep its log to errors.
vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_ERROR)


_DRIVER_HOLD: list[vtkRenderWindow] = []
_DRIVER_HOLD_LOCK = threading.Lock()


def _hold_gl_driver() -> None:
    """Keep one 1 x 1 off-screen render window open for the rest of the process, so the
    OpenGL driver stays loaded between previews.

    Closing a Plotter's window calls ``eglTerminate``, which on Mesa unloads the driver
    (``swrast_dri.so``) when no other window holds the display; the next Plotter loads
    it again, and each load maps a fresh 10 MiB executable code heap while the last
    one is never unmapped. 100 previews (``street --k 100``) grew the address space by
    1 GB and aborted under ``ulimit -v 3000000``. With this window open the driver and
    its heap stay, and every preview is still drawn by a Plotter of its own (the same
    pixels as before)."""
    with _DRIVER_HOLD_LOCK:
        if _DRIVER_HOLD:
            return
        win = vtkRenderWindow()
        win.SetOffScreenRendering(True)
        win.SetSize(1, 1)
        win.AddRenderer(vtkRenderer())
        win.Render()
        _DRIVER_HOLD.append(win)


def to_polydata(mesh: trimesh.Trimesh) -> pv.PolyData:
    faces = np.hstack([np.full((len(mesh.faces), 1), 3), mesh.faces]).ravel()
    poly = pv.PolyData(np.asarray(mesh.vertices, dtype=float), faces)
    colors = getattr(mesh.visual, "face_colors", None)
    if colors is not None and len(colors) == len(mesh.faces):
        poly.cell_data["rgb"] = np.asarray(colors)[:, :3].astype(np.uint8)
    return poly


def three_quarter_view(plotter: pv.Plotter, poly: pv.PolyData, zoom: float = 1.1) -> None:
    """Look at the facade (toward -Y in the canonical frame) from the front right,
    slightly from above."""
    lo = np.array(poly.bounds[::2])
    hi = np.array(poly.bounds[1::2])
    centre = (lo + hi) / 2
    direction = np.array([0.55, -1.0, 0.45])
    dist = 2.2 * float(np.linalg.norm(hi - lo))
    plotter.camera_position = [tuple(centre + dist * direction / np.linalg.norm(direction)),
                               tuple(centre), (0, 0, 1)]
    plotter.reset_camera()
    plotter.camera.zoom(zoom)


def _add_coloured(plotter: pv.Plotter, poly: pv.PolyData) -> None:
    if "rgb" in poly.cell_data:
        plotter.add_mesh(poly, scalars="rgb", rgb=True, smooth_shading=False)
    else:
        plotter.add_mesh(poly, color="tan")


def _ground(poly: pv.PolyData, margin: float = 0.15) -> pv.PolyData:
    lo = np.array(poly.bounds[::2])
    hi = np.array(poly.bounds[1::2])
    size = (hi - lo)[:2] * (1 + 2 * margin) + 10.0
    centre = (lo + hi) / 2
    return pv.Plane(center=(centre[0], centre[1], lo[2] - 0.05), direction=(0, 0, 1),
                    i_size=size[0], j_size=size[1])


def render_meshes(mesh: trimesh.Trimesh, out_png: str | Path, *, title: str = "",
                  size: tuple[int, int] = (1400, 700), zoom: float = 1.3) -> Path:
    """A three-quarter view (left) and a top view (right) of ``mesh`` to ``out_png``.
    A tall mesh (a tower) is not zoomed past the camera's fit, which would cut its top."""
    poly = to_polydata(mesh)
    ext = np.array(poly.bounds[1::2]) - np.array(poly.bounds[::2])
    if ext[2] > 1.5 * max(ext[0], ext[1]):
        zoom = min(zoom, 1.0)
    _hold_gl_driver()
    plotter = pv.Plotter(off_screen=True, shape=(1, 2), window_size=size, border=False)
    for col, top in ((0, False), (1, True)):
        plotter.subplot(0, col)
        plotter.set_background("white", top="#dfe8f0")
        plotter.add_mesh(_ground(poly), color="#ecebe6", smooth_shading=False)
        _add_coloured(plotter, poly)
        plotter.enable_lightkit()
        if top:
            plotter.view_xy()
            plotter.enable_parallel_projection()
            plotter.reset_camera()
            plotter.camera.zoom(1.15)
        else:
            three_quarter_view(plotter, poly, zoom=zoom)
        if title and col == 0:
            plotter.add_text(title, font_size=9, color="black", position="upper_left")
    out = Path(out_png)
    with atomic_path(out) as tmp:
        plotter.screenshot(str(tmp))
    plotter.close()
    return out


MAX_TRIANGLES = 3_000_000   # a preview's full geometry; past it, each part as its box


def render_layout(lay, db: PartDB, out_png: str | Path, **kw) -> Path:
    """The preview of a layout (see :func:`render_meshes`): its full geometry up to
    :data:`MAX_TRIANGLES`, else each part as its bounding box, as a city's overview
    does. (A 100 km building's full mesh asked VTK for gigabytes: std::bad_alloc, an
    abort, and half its files left.)"""
    from citysynth.export.assemble import triangle_count, world_boxes, world_mesh

    if triangle_count(lay, db) <= MAX_TRIANGLES:
        return render_meshes(world_mesh(lay, db), out_png, **kw)
    if kw.get("title"):
        kw["title"] += " (each part as its box)"
    return render_meshes(world_boxes(lay, db), out_png, **kw)


def contact_sheet(db: PartDB, library_dir: str | Path, out_png: str | Path, *,
                  columns: int = 12, tile: int = 200) -> Path:
    """Render every part of ``db`` into one PNG grid, labelled with id and length."""
    root = Path(library_dir)
    n = len(db.parts)
    rows = math.ceil(n / columns)
    _hold_gl_driver()
    plotter = pv.Plotter(off_screen=True, shape=(rows, columns),
                         window_size=(columns * tile, rows * tile), border=False)
    plotter.set_background("white")
    for i, part in enumerate(db.parts):
        plotter.subplot(i // columns, i % columns)
        mesh = trimesh.load(str(root / part.file), force="mesh")
        assert isinstance(mesh, trimesh.Trimesh)   # force="mesh" concatenates a scene
        poly = to_polydata(mesh)
        _add_coloured(plotter, poly)
        plotter.add_text(f"{part.id}\n{part.cls}, {part.length:g} m", font_size=7,
                         color="black", position="upper_left")
        plotter.enable_lightkit()
        three_quarter_view(plotter, poly)
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    plotter.screenshot(str(out))
    plotter.close()
    return out


def main(argv: list[str] | None = None) -> None:
    """``python -m citysynth.export.preview LIBRARY OUT.png``: the contact sheet of a library."""
    import sys

    from citysynth.parts_db import load_library

    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        raise SystemExit("usage: python -m citysynth.export.preview LIBRARY_DIR OUT.png")
    out = contact_sheet(load_library(args[0]), args[0], args[1], tile=170)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
