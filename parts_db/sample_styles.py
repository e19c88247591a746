"""The sample library's two facade styles and their profile families.

A style is a way of building (its windows, its colours); a family is one kind of
building within it (storeys, depth, cornice, roof), as a segmented street has several.
Each family comes in five variants that differ the way neighbouring buildings of one
kind do: a little taller storeys and a deeper range, or a lower ground floor and a
shallower one, a lighter cornice, a steeper roof. Parts are cut from these, so two
parts of one variant fit exactly, two variants of a family almost, and two families
poorly: the transition costs have many values and the solver has real choices.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from citysynth.parts_db.sample_profiles import Massing, Profile, profile
from citysynth.parts_db.sample_sweep import Windows

# How a family's buildings differ from one another: depth, upper storey height, ground
# storey height (m), cornice protrusion (factor), roof pitch (degrees), parapet (m). The
# steps are chosen so that no two variants' string courses or cornices meet corner to
# corner at a seam (parts_db.sample_sweep.joint_faces refuses that).
VARIANTS = ((0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
            (0.6, 0.15, 0.0, 0.8, 3.0, 0.2),
            (-0.5, 0.0, -0.4, 0.7, -4.0, 0.4),
            (0.4, -0.1, 0.2, 0.9, 6.0, -0.1),
            (-0.35, 0.05, -0.2, 0.95, -2.0, 0.1))


@dataclass(frozen=True)
class Family:
    key: str                       # "a", "b" ... ("a" is the style's principal family)
    title: str
    massing: Massing

    def variant(self, k: int) -> Massing:
        """Variant 0 is the family itself; 1-4 are its neighbours (see VARIANTS)."""
        depth, storey, ground, cornice, pitch, parapet = VARIANTS[k]
        m = self.massing
        return replace(m, depth=m.depth + depth, storey=m.storey + storey,
                       ground=m.ground + ground, pitch=m.pitch + pitch,
                       parapet=m.parapet + parapet,
                       cornice=tuple((round(p * cornice, 3), h) for p, h in m.cornice))

    def label(self, k: int) -> str:
        return f"{self.key}{k}"

    def profile(self, k: int, storeys: int | None = None) -> Profile:
        m = self.variant(k)
        if storeys is not None:
            m = replace(m, storeys=storeys, courses=tuple(c for c in m.courses if c < storeys))
        return profile(f"{self.key}{k}", m)


@dataclass(frozen=True)
class Style:
    name: str
    windows: Windows
    palette: dict[str, tuple[int, int, int]]
    families: tuple[Family, ...]
    bay_widths: tuple[float, ...]          # the bays a part's slices are made of
    balcony_share: float                   # parts with balconies
    corner_angles: tuple[int, ...]         # of the first two families (the others: 90)
    seed: int

    @property
    def bay_w(self) -> float:
        """The style's bay width (what a part of w metres divides into round(w / bay_w))."""
        return self.windows.bay


CLASSIC = Style(
    "classic", Windows(bay=2.6, width=1.2, depth=0.25),
    {"walls": (221, 205, 170), "walls_b": (214, 184, 138), "walls_c": (226, 200, 190),
     "walls_d": (204, 206, 196), "trim": (246, 242, 232), "roof": (156, 74, 56),
     "roof_b": (84, 88, 98), "roof_c": (170, 92, 64), "roof_d": (128, 62, 52),
     "window": (62, 86, 110), "door": (92, 58, 38), "balcony": (96, 98, 96)},
    (Family("a", "four storeys, gable roof", Massing(
        11.0, 4.2, 3.4, 4, ((0.08, 0.25), (0.14, 0.3), (0.2, 0.2)), "gable", pitch=35,
        course=(0.12, 0.22), courses=(1,))),
     Family("b", "five storeys, mansard roof", Massing(
         12.0, 4.4, 3.5, 5, ((0.06, 0.3), (0.13, 0.25), (0.2, 0.3)), "mansard", pitch=18,
         mansard=(1.3, 3.2), course=(0.1, 0.25), courses=(1, 2), tint="_b")),
     Family("c", "three storeys, steep gable", Massing(
         10.0, 3.8, 3.2, 3, ((0.12, 0.3), (0.2, 0.15)), "gable", pitch=45,
         course=(0.1, 0.18), courses=(1,), tint="_c")),
     Family("d", "six storeys, low gable", Massing(
         13.0, 4.6, 3.3, 6, ((0.08, 0.35), (0.14, 0.3), (0.2, 0.25)), "gable", pitch=27,
         course=(0.15, 0.3), courses=(1, 5), tint="_d"))),
    (2.4, 2.6, 2.8), 0.3, (90, 120, 135, 150), 11)

MODERN = Style(
    "modern", Windows(bay=3.2, width=2.2, depth=0.18, door=1.8),
    {"walls": (176, 180, 184), "walls_b": (228, 228, 222), "walls_c": (132, 96, 82),
     "walls_d": (150, 158, 164), "trim": (58, 60, 64), "roof": (104, 106, 110),
     "roof_b": (92, 96, 92), "roof_c": (112, 110, 104), "roof_d": (96, 100, 106),
     "window": (54, 80, 106), "door": (34, 34, 36), "balcony": (150, 168, 176)},
    (Family("a", "five storeys, parapet", Massing(
        12.0, 4.0, 3.1, 5, ((0.0, 1.2),), "parapet", parapet=0.9,
        window=(0.6, 2.1), ground_window=(0.4, 3.0))),
     Family("b", "six storeys and an attic", Massing(
         13.0, 4.2, 3.1, 6, ((0.0, 1.1),), "attic", parapet=0.8, attic=(2.2, 3.1),
         window=(0.6, 2.1), ground_window=(0.4, 3.0), tint="_b")),
     Family("c", "four storeys, slab roof", Massing(
         12.0, 4.2, 3.2, 4, ((0.2, 0.35),), "flat", window=(0.5, 2.2),
         ground_window=(0.3, 3.2), tint="_c")),
     Family("d", "eight storeys, parapet", Massing(
         14.0, 4.5, 3.0, 8, ((0.0, 1.3),), "parapet", parapet=1.0, window=(0.6, 2.0),
         ground_window=(0.4, 3.3), course=(0.15, 0.3), courses=(1,), tint="_d"))),
    (3.0, 3.2, 3.4), 0.5, (90, 120, 135, 150), 12)

STYLES = (CLASSIC, MODERN)
