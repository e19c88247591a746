"""One entry point for every output format of a layout, like trimesh's
``exchange/export.py``: :func:`write` picks the writer by format name, each writer
lives in its own module (``layout.py`` JSON, ``usd.py``, ``gltf.py``, ``preview.py``
PNG) and writes atomically.

The PNG writer is imported only when a preview is asked for: pyvista and VTK take
about a second to import, which a city worker writing USD alone should not pay.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Literal

from citysynth.export.gltf import write_glb
from citysynth.export.imports import import_shielded
from citysynth.export.layout import Layout
from citysynth.export.usd import CUTS_SUFFIX, write_layouts
from citysynth.export.usd import write_layout as write_usd
from citysynth.parts_db import PartDB
from citysynth.parts_db.files import write_text

Format = Literal["json", "usd", "glb", "png"]
FORMATS: tuple[Format, ...] = ("json", "usd", "glb", "png")
SUFFIX: dict[Format, str] = {"json": ".layout.json", "usd": ".usda", "glb": ".glb",
                             "png": ".png"}
BESIDE: dict[Format, tuple[str, ...]] = {"usd": (CUTS_SUFFIX,)}
"""Suffixes of the files a format may write beside its main ones, under the layouts'
name (a building's cut prototypes, ``<name>.cuts.usdc``)."""


def write_json(lay: Layout, db: PartDB, path: Path) -> Path:
    return write_text(path, lay.to_json())


def write_png(lay: Layout, db: PartDB, path: Path) -> Path:
    # pyvista only when previewing; Ctrl-C inside VTK's import crashed the process
    render_layout = import_shielded("citysynth.export.preview").render_layout
    title = f"{lay.name}  #{lay.rank}  cost {lay.cost:g}  {len(lay.instances)} parts"
    return render_layout(lay, db, path, title=title)


WRITERS: dict[Format, Callable[[Layout, PartDB, Path], Path]] = {
    "json": write_json, "usd": write_usd, "glb": write_glb, "png": write_png}


def write(lay: Layout, db: PartDB, stem: str | Path, fmt: Format) -> Path:
    """Write ``lay`` as ``fmt`` to ``stem`` + the format's suffix; the path written."""
    if fmt not in WRITERS:
        raise ValueError(f"unknown output format {fmt!r}; formats are {', '.join(FORMATS)}")
    stem = Path(stem)
    return WRITERS[fmt](lay, db, stem.with_name(stem.name + SUFFIX[fmt]))


def write_ranks(layouts: Sequence[Layout], db: PartDB, stems: Sequence[str | Path],
                fmt: Format) -> list[Path]:
    """Write a building's or block's layouts (its k best, one stem each) as ``fmt``;
    the paths written. USD writes them together: their layers share one file of the
    prototypes they cut (:func:`~citysynth.export.usd.write_layouts`)."""
    if fmt == "usd":
        return write_layouts(layouts, db, [Path(s).with_name(Path(s).name + SUFFIX[fmt])
                                           for s in stems])
    return [write(lay, db, stem, fmt) for lay, stem in zip(layouts, stems, strict=True)]
