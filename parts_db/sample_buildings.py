"""Complete buildings of the sample library, for street fronts (the paper's Fig. 7).

In a street, what a building shows its neighbour is its party wall: the height and the
roof of its end. Each building here has a main body and, at each end, a wing one or two
bays wide whose profile meets the next building's: the ends of a style's buildings are
drawn from a ring of end profiles (storeys rising, then falling in a second variant, so
no profile repeats), and a building's left end is one of them, its right end the next.
Two buildings fit exactly only when one's right end is the other's left end, so a row
without a mismatched party wall walks round the ring and meets many buildings; a
building beside its own copy shows a step. Widths, bodies, doors and balconies are
drawn from a fixed seed, so the files are the same on every run.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from citysynth.parts_db.sample_mesh import PartMesh
from citysynth.parts_db.sample_profiles import Profile
from citysynth.parts_db.sample_styles import STYLES, Style
from citysynth.parts_db.sample_sweep import Slice, straight

QUANTUM = 0.2
COUNT = 72            # buildings, alternating between the styles
WIDTHS = (30, 120)    # quanta: 6-24 m
# the ring of end profiles of a style: (variant of its principal family, storeys)
RING = ((0, 3), (0, 4), (0, 5), (0, 6), (1, 7), (1, 6), (1, 5), (1, 4))


def ring_profile(style: Style, node: int) -> Profile:
    variant, storeys = RING[node % len(RING)]
    return style.families[0].profile(variant, storeys=storeys)


def _slices(style: Style, w: float, left: Profile, right: Profile, body: Profile,
            rng: np.random.Generator) -> list[Slice]:
    """Wing, body, wing on whole bays (a narrow building: its two ends only), a door in
    the body and, sometimes, balconies up one inner bay of it."""
    bays = max(2, round(w / style.windows.bay))
    bw = w / bays
    wing = 1 if bays < 7 else 2
    cuts = [0, 1, bays] if bays < 4 else [0, wing, bays - wing, bays]
    profiles = [left, right] if bays < 4 else [left, body, right]
    main = len(profiles) // 2
    slices = []
    for k, (a, b) in enumerate(zip(cuts, cuts[1:], strict=False)):
        n = b - a
        door = frozenset({int(rng.integers(0, n))}) if k == main else frozenset()
        balc: frozenset[tuple[int, int]] = frozenset()
        m = profiles[k].massing
        if k == main and m is not None and n >= 3 and rng.random() < 0.4:
            bay = int(rng.integers(1, n - 1))   # not beside a wing: over its roof
            balc = frozenset((s, bay) for s in range(2, m.storeys))
        slices.append(Slice(round(a * bw, 6), round(b * bw, 6), profiles[k], door, balc))
    return slices


def closed(pm: PartMesh) -> bool:
    """Every edge of the part's bodies met by exactly one edge running the other way."""
    m = pm.trimesh()
    m.merge_vertices()
    directed = np.concatenate([m.faces[:, [0, 1]], m.faces[:, [1, 2]], m.faces[:, [2, 0]]])
    fwd = {tuple(e) for e in directed.tolist()}
    return len(fwd) == len(directed) and all((b, a) in fwd for a, b in fwd)


def _build(style: Style, slices: list[Slice]) -> PartMesh:
    """The building's mesh; balconies on a body beside a wing of another height can
    cut through the wing's wall where the sweep does not join them, and are left out
    there (the part stays a set of closed bodies, as every sample part is)."""
    pm = PartMesh(style.palette)
    straight(pm, slices, style.windows)
    if closed(pm) or not any(sl.balconies for sl in slices):
        return pm
    pm = PartMesh(style.palette)
    straight(pm, [replace(sl, balconies=frozenset()) for sl in slices], style.windows)
    return pm


def building_parts() -> Iterator[tuple[str, str, PartMesh, float]]:
    """(id, style, mesh, width) of the 72 buildings, 6-24 m wide, each with one door;
    the steps of each style's ring taken in turn, so each has buildings of many widths."""
    rng = np.random.default_rng(2024)
    widths = np.sort(rng.choice(np.arange(WIDTHS[0], WIDTHS[1] + 1), size=COUNT,
                                replace=False)) * QUANTUM
    for i, w in enumerate(widths):
        style = STYLES[i % 2]
        w = round(float(w), 6)
        node = (i // 2) % len(RING)    # every step of the ring, in every width range
        left, right = ring_profile(style, node), ring_profile(style, node + 1)
        # the body: the taller end's variant, as tall or a storey taller
        variant, storeys = max(RING[node % len(RING)], RING[(node + 1) % len(RING)],
                               key=lambda vs: vs[1])
        storeys = min(storeys + int(rng.integers(0, 2)), 8)
        body = style.families[0].profile(variant, storeys=storeys)
        pm = _build(style, _slices(style, w, left, right, body, rng))
        yield f"bldg_{i:02d}_{w:.1f}m_{style.name}_{storeys}s", style.name, pm, w
