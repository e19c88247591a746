"""Cross-section profiles of the sample library's facade parts.

A profile is the outline of a building range cut across its length, in the canonical
section axes (README, "The canonical frame"): u points out of the street facade (the
facade is u = 0, the mass at u < 0, cornices at u > 0) and v up. Every part of a style
is a profile, or a sequence of profiles, swept along the facade line, so a part's in-
and out-sections are exactly its first and last profile and the transition costs are the
areas where profiles disagree.

Profiles are symmetric about the middle of the depth (u = -depth / 2): the courtyard
side repeats the street side's storeys, cornice and windows. That is what lets corners,
and T parts whose wing has the main range's profile, close as one solid with mitred
hips and valleys (see :mod:`parts_db.sample_sweep`).

Each edge of the outline carries its material (walls, trim, roof) and, for a wall face
between two floor lines, the storey's window band.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import shapely

# No profile reaches further than this past its facade line (cornices, string courses):
# the 3D audit of assembled layouts allows 0.3 m beyond a building's outline, and a
# mitred cornice reaches REACH / sin(angle / 2) past a convex corner, 0.28 m at 90
# degrees. (Balconies, on straight runs only, reach 0.28 m.)
REACH = 0.2


@dataclass(frozen=True)
class Band:
    """A storey's wall face: where its windows go."""

    side: str          # "front" (street), "back" (courtyard) or "attic" (set back)
    storey: int        # 0 = ground floor
    z0: float          # the face's bottom and top
    z1: float
    sill: float        # window bottom and top
    head: float


@dataclass(frozen=True)
class Massing:
    """The parameters of one profile: storeys, depth, cornice and roof."""

    depth: float
    ground: float                  # ground storey height
    storey: float                  # upper storey height
    storeys: int
    cornice: tuple[tuple[float, float], ...]   # (protrusion, height) steps, bottom up
    roof: str                      # gable | mansard | parapet | attic | flat
    pitch: float = 35.0            # degrees: gable, mansard's upper slope
    mansard: tuple[float, float] = (1.2, 3.0)   # lower slope: inset, rise
    course: tuple[float, float] = (0.0, 0.0)    # string course: protrusion, height
    courses: tuple[int, ...] = ()               # floor lines (storey index) with a course
    parapet: float = 0.9           # parapet above the roof surface (parapet, attic)
    coping: float = 0.3            # parapet thickness
    attic: tuple[float, float] = (2.0, 3.0)     # setback, height of an attic storey
    window: tuple[float, float] = (0.9, 1.9)    # sill above the floor, window height
    ground_window: tuple[float, float] = (0.9, 2.2)
    tint: str = ""                 # suffix of this family's wall and roof materials

    def eaves(self) -> float:
        return self.ground + (self.storeys - 1) * self.storey

    def floors(self) -> list[float]:
        return [0.0] + [self.ground + k * self.storey for k in range(self.storeys - 1)]


@dataclass(frozen=True)
class Profile:
    """A closed counter-clockwise outline in (u, v) with per-edge material and band."""

    name: str
    depth: float
    points: tuple[tuple[float, float], ...]
    materials: tuple[str, ...]      # edge i runs points[i] -> points[i + 1]
    bands: tuple[Band | None, ...]
    massing: Massing | None = field(default=None, compare=False, repr=False)

    @property
    def wall(self) -> str:
        """The material of this profile's walls (end walls, fire walls, reveals' backs)."""
        return "walls" + (self.massing.tint if self.massing else "")

    @property
    def centre(self) -> float:
        return -self.depth / 2

    @property
    def height(self) -> float:
        return max(v for _u, v in self.points)

    def polygon(self) -> shapely.Polygon:
        return shapely.Polygon(self.points)

    def edges(self):
        n = len(self.points)
        for i in range(n):
            yield i, (i + 1) % n


def _r(x: float) -> float:
    return round(x, 6) + 0.0


def _front_half(m: Massing) -> tuple[list[tuple[float, float]], list[str], list[Band | None]]:
    """The outline from the bottom middle, out along the ground, up the street facade,
    over the cornice and the roof to the top middle."""
    uc = -m.depth / 2
    pts = [(uc, 0.0), (0.0, 0.0)]
    mats: list[str] = ["walls"]
    bands: list[Band | None] = [None]

    def go(u: float, v: float, mat: str, band: Band | None = None) -> None:
        pts.append((u, v))
        mats.append(mat)
        bands.append(band)

    floors = m.floors() + [m.eaves()]
    cp, ch = m.course
    for k in range(m.storeys):
        z0, z1 = floors[k], floors[k + 1]
        top = z1 - ch if (k + 1) in m.courses else z1
        sill_h, win_h = m.ground_window if k == 0 else m.window
        sill = z0 + sill_h
        head = min(sill + win_h, top - 0.35)
        go(0.0, top, "walls", Band("front", k, z0, top, sill, head))
        if top < z1:  # a string course under the next floor line
            go(cp, top, "trim")
            go(cp, z1, "trim")
            go(0.0, z1, "trim")
    z = m.eaves()
    u = 0.0
    for prot, h in m.cornice:
        if prot != u:
            go(prot, z, "trim")
        z += h
        u = prot
        go(u, z, "trim")
    _roof(m, go, u, z, uc)
    return pts, mats, bands


def _roof(m: Massing, go, u: float, z: float, uc: float) -> None:
    """The roof from the cornice top (u, z) to the middle of the depth."""
    tan = math.tan(math.radians(m.pitch))
    if m.roof == "gable":
        go(uc, z + (u - uc) * tan, "roof")
    elif m.roof == "mansard":
        inset, rise = m.mansard
        go(u - inset, z + rise, "roof")
        go(uc, z + rise + (u - inset - uc) * tan, "roof")
    elif m.roof in ("parapet", "attic"):
        roof_z = z - m.parapet
        go(-m.coping, z, "trim")
        go(-m.coping, roof_z, "trim")
        if m.roof == "attic":
            setback, height = m.attic
            go(-setback, roof_z, "roof")
            top = roof_z + height
            go(-setback, top, "walls", Band("attic", m.storeys, roof_z, top, roof_z + 0.6,
                                            top - 0.45))
            go(-setback + 0.6, top, "trim")
            go(-setback + 0.6, top + 0.35, "trim")
            go(uc, top + 0.35, "roof")
        else:
            go(uc, roof_z, "roof")
    elif m.roof == "flat":
        go(uc, z, "roof")
    else:
        raise ValueError(f"unknown roof {m.roof!r}")


def profile(name: str, m: Massing) -> Profile:
    """The symmetric outline of ``m``: the front half, then its mirror image about the
    middle of the depth (the courtyard side)."""
    front, mats, bands = _front_half(m)
    front = [(_r(u), _r(v)) for u, v in front]
    mirror = [(_r(-m.depth - u), v) for u, v in front]
    points = front + mirror[-2:0:-1]
    edge_mats = mats + mats[::-1]
    edge_bands: list[Band | None] = list(bands)
    for b in bands[::-1]:
        edge_bands.append(None if b is None else replace(b, side="back" if b.side == "front"
                                                          else b.side + "_back"))
    edge_mats = [x + m.tint if x in ("walls", "roof") else x for x in edge_mats]
    prof = Profile(name, m.depth, tuple(points), tuple(edge_mats), tuple(edge_bands), m)
    reach = max(u for u, _v in points)
    if reach > REACH + 1e-9:
        raise ValueError(f"profile {name}: reaches {reach:g} m past its facade (at most "
                         f"{REACH:g} m)")
    poly = prof.polygon()
    if not poly.is_valid or poly.exterior.is_ccw is False:
        raise ValueError(f"profile {name}: outline is not a simple counter-clockwise ring")
    return prof


def lifted(prof: Profile, dz: float) -> Profile:
    """``prof`` with its ground storey ``dz`` higher (everything above it moves up): one
    part's own small deviation from its kind (:func:`parts_db.sample.lift`)."""
    if not dz or prof.massing is None:
        return prof
    m = prof.massing
    return profile(prof.name, replace(m, ground=round(m.ground + dz, 6)))
