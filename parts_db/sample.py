"""The sample library's generator: real mesh files and a manifest, deterministic.

``python -m citysynth.parts_db.sample [OUT]`` (or ``make library``) writes
``examples/library``:

* two facade styles (:mod:`parts_db.sample_styles`), each with four profile families
  in five variants. Middle parts are cut from them like segments of real streets: a
  stretch of one variant, or a seam between two variants of a family, or a step from
  one family to another (a lower neighbour, a fire wall). End parts for every family,
  corners of 90, 120, 135 and 150 degrees, convex and concave, and per family a T part,
  its twin with an entrance, and a T in the family's first variant, all with the same
  legs; every part deviates a little from its profile (:data:`JITTER`), as segmented
  parts of one kind do, so look-alike parts meet at a small cost and layouts rarely tie;
* tower parts (ground floors, floors of varied outlines, areas and heights, roofs);
* complete buildings 6-24 m wide for street fronts.

Every part is one closed solid per body (:mod:`parts_db.sample_sweep`), its faces keep
their materials (walls, roof, trim, glass, doors, balconies), and windows, doors and
balconies are named sub-meshes of the GLB scene that ingest counts.
"""

from __future__ import annotations

import math
import sys
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from citysynth.parts_db.sample_buildings import building_parts
from citysynth.parts_db.sample_mesh import PartMesh
from citysynth.parts_db.sample_profiles import Profile, lifted, profile
from citysynth.parts_db.sample_styles import CLASSIC, MODERN, STYLES, Family, Style
from citysynth.parts_db.sample_sweep import Slice, corner, straight, t_part
from citysynth.parts_db.sample_towers import tower_parts

OUT = Path(__file__).resolve().parent.parent / "examples" / "library"  # in the repository
QUANTUM = 0.2
__all__ = ["CLASSIC", "MODERN", "OUT", "STYLES", "facade_chunk", "generate", "middle_specs",
           "parts"]


@dataclass
class Entry:
    id: str
    cls: str
    style: str
    mesh: PartMesh
    meta: dict = field(default_factory=dict)


def _up(x: float) -> float:
    """x rounded up to the quantum."""
    return round(math.ceil(x / QUANTUM - 1e-9) * QUANTUM, 6)


def _label(w: float) -> str:
    return f"{w:.1f}"


# A part's own deviation from its profile: its ground storey (and so everything above it)
# sits up to this much higher or lower, as two segmented buildings of one kind never
# measure the same. Two different parts of one profile then meet at a small cost (about
# 0.01 m2 per mm), a part next to itself at none, so layouts that differ only in which of
# several look-alike parts they use no longer tie; variants of a family differ by
# tens of m2, families by more, so the jitter never outweighs them.
JITTER = 0.02


def lift(part_id: str) -> float:
    """The part's ground storey deviation in metres, -JITTER..JITTER in 1 mm steps,
    fixed by its id (deterministic, independent of generation order)."""
    steps = round(JITTER * 1000)
    return (zlib.crc32(part_id.encode()) % (2 * steps + 1) - steps) / 1000


# --- middle parts ----------------------------------------------------------------------------

# Steps from one family to another: (family, variant) on each side. They land on a
# variant other than the next family's own, so a detour into another family and back
# always costs something.
STEPS = ((("a", 0), ("b", 3)), (("b", 2), ("a", 0)), (("a", 0), ("c", 3)),
         (("c", 2), ("a", 0)), (("b", 0), ("d", 3)), (("d", 2), ("b", 0)))
# Seams between variants of a family inside one part: from the family's own profile to
# variants 1 and 3, and from 2 and 4 back to it (never there and back, so that an
# excursion away from the family's own profile is never free).
SEAMS = ((0, 1), (2, 0), (0, 3), (4, 0))
# ... except from variant 1 back to the family's own profile: variant 1 is the T parts'
# other profile, and with a way there and a way back a variant T costs about what the
# family's own does (the small per-part deviations, see JITTER), so the k best layouts
# of a building vary the part at the T as the paper's Fig. 6 does.
BACK = (1, 0)


@dataclass(frozen=True)
class MidSpec:
    """A middle part before it is built: its slices (profiles, doors, balconies)."""

    id: str
    slices: tuple[Slice, ...]

    @property
    def length(self) -> float:
        return self.slices[-1].x1


class _Cutter:
    """Cuts a style's middle parts: slices of whole bays, with doors and balconies
    drawn from the style's seeded generator."""

    def __init__(self, style: Style) -> None:
        self.style = style
        self.rng = np.random.default_rng(style.seed)

    def width(self, bays: int, bay: float | None = None) -> float:
        bw = bay if bay is not None else float(self.rng.choice(self.style.bay_widths))
        return round(bays * bw, 6)

    def spec(self, widths: list[float], profiles: list[Profile]) -> MidSpec:
        style, rng = self.style, self.rng
        slices, x = [], 0.0
        balconies = rng.random() < style.balcony_share
        for w, prof in zip(widths, profiles, strict=True):
            bays = max(1, round(w / style.windows.bay))
            doors = frozenset({int(rng.integers(0, bays))}) if rng.random() < 0.45 \
                else frozenset()
            balc: frozenset[tuple[int, int]] = frozenset()
            if balconies:
                bay = int(rng.integers(0, bays))
                m = prof.massing
                upper = range(2, m.storeys) if m is not None else range(0)
                balc = frozenset((st, bay) for st in upper)
            slices.append(Slice(round(x, 6), round(x + w, 6), prof, doors, balc))
            x += w
        tag = "_".join(dict.fromkeys(p.name for p in profiles))
        return MidSpec(f"{style.name}_mid_{_label(x)}_{tag}", tuple(slices))


def middle_specs(style: Style) -> list[MidSpec]:
    """Per family: one stretch of each variant (its own profile three style bays wide,
    so a stretch between two of its key parts is free only where the length is a
    multiple of that; no two parts of one profile, whose order would not matter and so
    tie layouts), and the seams; then the steps between families."""
    cut = _Cutter(style)
    fam = {f.key: f for f in style.families}
    specs = []
    for f in style.families:
        specs.append(cut.spec([cut.width(3, style.windows.bay)], [f.profile(0)]))
        for k in (1, 2, 3, 4):
            specs.append(cut.spec([cut.width(int(cut.rng.integers(1, 5)))], [f.profile(k)]))
        for a, b in SEAMS:
            widths = [cut.width(int(cut.rng.integers(1, 3))) for _ in range(2)]
            specs.append(cut.spec(widths, [f.profile(a), f.profile(b)]))
    for (fa, ka), (fb, kb) in STEPS:
        widths = [cut.width(2), cut.width(2)]
        specs.append(cut.spec(widths, [fam[fa].profile(ka), fam[fb].profile(kb)]))
    for f in style.families:      # cut last: the parts above keep their random draws
        widths = [cut.width(int(cut.rng.integers(1, 3))) for _ in range(2)]
        specs.append(cut.spec(widths, [f.profile(BACK[0]), f.profile(BACK[1])]))
    return specs


def middle_parts(style: Style) -> Iterator[Entry]:
    for spec in middle_specs(style):
        pm = PartMesh(style.palette)
        dz = lift(spec.id)
        straight(pm, [replace(s, profile=lifted(s.profile, dz)) for s in spec.slices],
                 style.windows)
        yield Entry(spec.id, "middle", style.name, pm, {"length": round(spec.length, 1)})


# --- key parts ------------------------------------------------------------------------------

def _suffix(f: Family, k: int = 0) -> str:
    """The principal family's own profile keeps the plain ids (classic_end_left,
    classic_t ...); others add the family and variant (classic_t_b, classic_t_a1)."""
    if k:
        return f"_{f.key}{k}"
    return "" if f.key == "a" else f"_{f.key}"


def _reach(prof: Profile) -> float:
    """How far the profile reaches out of the facade (its cornice)."""
    return max(u for u, _v in prof.points)


def corner_leg(prof: Profile, angle: float, convex: bool, bay: float) -> float:
    """Long enough that every line of the profile passes the mitre and two bays of
    windows fit beyond it on the shorter side."""
    half = math.radians(angle) / 2
    inner = prof.depth if convex else _reach(prof)
    return _up(inner / math.tan(half) + 2 * bay + 0.6)


def key_variants(style: Style) -> Iterator[tuple[Family, int, tuple[int, ...]]]:
    """(family, variant, corner angles): every family's own profile with end parts and
    corners of 90 degrees (the first two families: of every angle of the style), and
    every family's variant 1 with a T part (the first family's with 90 degree corners
    too), so the part at a T or a corner is a choice within a family as well."""
    for i, f in enumerate(style.families):
        yield f, 0, style.corner_angles if i < 2 else (90,)
    for i, f in enumerate(style.families):
        yield f, 1, (90,) if i == 0 else ()


def key_parts(style: Style) -> Iterator[Entry]:
    win = style.windows
    for f, k, angles in key_variants(style):
        base = f.profile(k)
        sx = _suffix(f, k)
        if k == 0:
            for cls, gables in (("end_left", (True, False)), ("end_right", (False, True))):
                pm = PartMesh(style.palette)
                pid = f"{style.name}_{cls}{sx}"
                straight(pm, [Slice(0.0, _up(2 * win.bay), lifted(base, lift(pid)))], win,
                         gables=gables)
                yield Entry(pid, cls, style.name, pm)
        for angle in angles:
            for convex in (True, False):
                pm = PartMesh(style.palette)
                kind = "convex" if convex else "concave"
                pid = f"{style.name}_corner_{angle}_{kind}{sx}"
                corner(pm, lifted(base, lift(pid)), angle, convex,
                       corner_leg(base, angle, convex, win.bay), win)
                yield Entry(pid, "corner", style.name, pm, {"angle": angle, "convex": convex})
        # every T of a family has the legs of the family's own, so that a building's
        # stages fit either and the cost alone picks the T (variant 1 is up to 0.6 m
        # deeper: a little less of its legs shows beyond the wing); the family's own
        # T also comes with an entrance on the street front, opposite the wing: the same
        # building with a door cut in, so the same section (and deviation) as the plain one
        own = f.profile(0)
        reach = _up(own.depth + _reach(own) + 2 * win.bay + 0.4)
        bays = round(2 * reach / win.bay)
        pid = f"{style.name}_t{sx}"
        prof = lifted(base, lift(pid))
        for tag, doors in (("", frozenset()), ("_door", frozenset({bays // 2}))):
            if tag and k:
                continue
            pm = PartMesh(style.palette)
            t_part(pm, prof, reach, reach, win, doors)
            yield Entry(pid + tag, "t_junction", style.name, pm)


# --- complete buildings and towers ---------------------------------------------------------

def facade_chunk(style: Style, x0: float, x1: float, storeys: int, *, door: int | None,
                 balconies: set[int], roof: bool = True) -> PartMesh:
    """A building of the style's principal family from x0 to x1 with ``storeys``, a door
    in bay ``door`` and balconies in every bay of the ``balconies`` storeys, under its
    roof or (``roof`` false) a flat one (used by ``bench/ingest.py`` to write libraries
    of any size)."""
    fam = style.families[0]
    m = replace(fam.massing, storeys=storeys,
                courses=tuple(c for c in fam.massing.courses if c < storeys))
    if not roof:
        m = replace(m, roof="flat", cornice=m.cornice[:1] or ((0.3, 0.3),))
    bays = max(1, round((x1 - x0) / style.bay_w))
    sl = Slice(x0, x1, profile(f"{fam.key}_chunk", m),
               frozenset() if door is None else frozenset({door}),
               frozenset((s, b) for s in balconies if 0 < s < storeys for b in range(bays)))
    pm = PartMesh(style.palette)
    straight(pm, [sl], style.windows)
    return pm


def buildings() -> Iterator[Entry]:
    """72 buildings for street fronts (:mod:`parts_db.sample_buildings`)."""
    for pid, style, pm, w in building_parts():
        yield Entry(pid, "building", style, pm, {"length": round(w, 1)})


def towers() -> Iterator[Entry]:
    for pid, cls, pm in tower_parts():
        yield Entry(pid, cls, "tower", pm)


def parts() -> Iterator[Entry]:
    """Every part of the library, in manifest order."""
    for style in STYLES:
        yield from middle_parts(style)
        yield from key_parts(style)
    yield from towers()
    yield from buildings()


# --- writing -------------------------------------------------------------------------------

def manifest(entries: list[Entry]) -> str:
    lines = ["# The citysynth sample library, written by parts_db/sample.py (make library).",
             "# Canonical frame: +X along the primary dimension, facade toward -Y, +Z up.",
             "", "[library]", 'name = "citysynth sample"', f"quantum = {QUANTUM}",
             'units = "m"', ""]
    for e in entries:
        lines += ["[[part]]", f'id = "{e.id}"', f'file = "meshes/{e.id}.glb"',
                  f'class = "{e.cls}"', f'style = "{e.style}"']
        if "angle" in e.meta:
            lines += [f"angle = {e.meta['angle']}",
                      f"convex = {str(e.meta['convex']).lower()}"]
        if "length" in e.meta:
            lines.append(f"length = {e.meta['length']}")
        lines.append("")
    return "\n".join(lines)


def generate(out: Path = OUT) -> list[dict]:
    """Write the meshes and manifest.toml into ``out``; returns the manifest entries."""
    mesh_dir = out / "meshes"
    mesh_dir.mkdir(parents=True, exist_ok=True)
    entries = list(parts())
    ids = [e.id for e in entries]
    if len(set(ids)) != len(ids):
        raise ValueError("duplicate part ids in the sample library")
    for e in entries:
        (mesh_dir / f"{e.id}.glb").write_bytes(e.mesh.glb())
    (out / "manifest.toml").write_text(manifest(entries), encoding="utf-8")
    return [{"id": e.id, "file": f"meshes/{e.id}.glb", "cls": e.cls, "style": e.style,
             **e.meta} for e in entries]


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    n = len(generate(target))
    print(f"wrote {n} parts to {target}")
