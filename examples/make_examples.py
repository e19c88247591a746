"""Regenerate the generated examples (``make examples``); a test checks that the files in
the repository match what this writes.

Problems come from :mod:`pipeline.samples`; the GeoJSON inputs are drawn here in local
metres and written as lon/lat (RFC 7946) around a point in Bonn.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from citysynth.skeletons import lonlat_from_local
from citysynth.solver.samples import street_front

HERE = Path(__file__).resolve().parent
ORIGIN = (7.1, 50.73)


def _fc(*features) -> dict:
    return {"type": "FeatureCollection", "features": list(features)}


def _line(points, **props) -> dict:
    return {"type": "Feature", "properties": props,
            "geometry": {"type": "LineString", "coordinates": lonlat_from_local(points, ORIGIN)}}


def _polygon(*rings, **props) -> dict:
    coords = [lonlat_from_local([*r, r[0]], ORIGIN) for r in rings]
    return {"type": "Feature", "properties": props,
            "geometry": {"type": "Polygon", "coordinates": coords}}


def t_building() -> dict:
    """A T-shaped building: a 63.6 m street front with 1-3 doors on each side of the
    T, a 40 m wing behind its middle that turns into a 31.8 m back range; facades face
    the right of each line."""
    return _fc(_line([(0, 0), (63.6, 0)], id="front", constraints={"doors": [1, 3]}),
               _line([(31.8, 0), (31.8, 40), (63.6, 40)], id="wing"))


def ring_with_wings() -> dict:
    """The paper's Fig. 1(c): a 72 x 60 m courtyard ring (drawn clockwise, so its main
    facades face the courtyard; the sample parts have windows on both faces) with a
    wing out of the middle of every side, one of them with a T of its own: a 77 m wing
    south whose T at 45 m sends a 32 m branch east. The T parts reach about 19 m along
    each leg, so T junctions stand at least two legs apart and every side of the ring
    runs from a corner to a T; wings of 32 m close in both sample styles (T leg, end
    part and modules). Facades face the right of each line."""
    return _fc(_line([(0, 0), (0, 60), (72, 60), (72, 0), (0, 0)], id="ring"),
               _line([(36, 0), (36, -45), (36, -77)], id="south_wing"),
               _line([(36, -45), (68, -45)], id="branch"),
               _line([(36, 60), (36, 92)], id="north_wing"),
               _line([(0, 30), (-32, 30)], id="west_wing"),
               _line([(72, 30), (104, 30)], id="east_wing"))


def ring_outward_wings() -> dict:
    """A 72 x 60 m courtyard ring whose facades face out to the street (drawn
    anticlockwise) with a wing on either side of it: a 36 m wing out of the south side
    into the street (its T part stands turned over, see ``export/t_poses.py``) and a 32 m
    wing from the north side into the courtyard, behind the facade. Facades face the
    right of each line."""
    return _fc(_line([(0, 0), (72, 0), (72, 60), (0, 60), (0, 0)], id="ring"),
               _line([(36, 0), (36, -36)], id="street_wing"),
               _line([(36, 60), (36, 28)], id="courtyard_wing"))


def h_building() -> dict:
    """An H: two 90 m ranges facing out, east and west, joined in their middles by a
    48 m bar that is the wing of both T junctions (its facade faces south: at the east
    T the part stands turned end for end). Facades face the right of each line."""
    return _fc(_line([(0, 90), (0, 0)], id="west_range"),
               _line([(48, 0), (48, 90)], id="east_range"),
               _line([(0, 45), (48, 45)], id="bar"))


def ladder_building() -> dict:
    """A ladder: two 150 m ranges facing out, east and west, joined by two 48 m bars
    (each the wing of the T junctions at both its ends), so the bars and the ranges
    between them close a courtyard. Facades face the right of each line."""
    return _fc(_line([(0, 150), (0, 0)], id="west_range"),
               _line([(48, 0), (48, 150)], id="east_range"),
               _line([(0, 45), (48, 45)], id="south_bar"),
               _line([(0, 105), (48, 105)], id="north_bar"))


def footprint_courtyard() -> dict:
    """A 60 x 50 m house with a 20 x 14 m courtyard (two cycles)."""
    return _fc(_polygon([(0, 0), (60, 0), (60, 50), (0, 50)],
                        [(20, 18), (20, 32), (40, 32), (40, 18)], id="house"))


def block() -> dict:
    """A city block with a cut corner (two 135° corners) and a notch (a concave corner),
    drawn so the sample library's modern parts (all multiples of 0.4 m) can fill every
    edge within half a quantum."""
    a = 41.2 / math.sqrt(2)          # the cut: 41.2 m long at 45°
    x, y = 56.4 + a, 56.4 + a
    return _fc(_polygon([(0, 0), (56.4, 0), (x, a), (x, y), (x - 40, y), (x - 40, y - 40),
                         (0, y - 40)], id="block"))


GENERATED = {
    "street_front.json": lambda: street_front(83.4, k=5),
    "street_front_3res.json": lambda: street_front(60.0, resources=3, k=5),
    "skeletons/t_building.geojson": t_building,
    "skeletons/footprint_courtyard.geojson": footprint_courtyard,
    "skeletons/ring_with_wings.geojson": ring_with_wings,
    "skeletons/ring_outward_wings.geojson": ring_outward_wings,
    "skeletons/h_building.geojson": h_building,
    "skeletons/ladder_building.geojson": ladder_building,
    "blocks/block.geojson": block,
}


def render(name: str) -> str:
    return json.dumps(GENERATED[name](), indent=1) + "\n"


def main() -> None:
    for name in GENERATED:
        path = HERE / name
        path.parent.mkdir(exist_ok=True)
        path.write_text(render(name), encoding="utf-8")
        print(f"wrote examples/{name}")


if __name__ == "__main__":
    main()
