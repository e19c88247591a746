"""``city.toml``: how a city run builds its blocks. Validated; errors name the key.

Every key is optional; the defaults build a city from one library in its first style.

```toml
library = "../library"      # part library folder (relative to this file)
style = "classic"           # default: the library's first style
k = 3                       # layouts solved per block
pick = "vary"               # "best": always the best; "vary": one of the k per block,
seed = 7                    #   chosen from the seed and the block's id (deterministic)
stretch = 0.005             # a stage's length may be met within this fraction
slack = 0.3                 #   or within this many metres, whichever is larger
corner_tolerance = 25.0     # degrees a corner part may be bent to fit a corner
mitre_cost = 10.0           # extra cost of a mitre (two end parts) at a corner
min_edge = 4.0              # shorter block edges are absorbed into their corners
min_width = 8.0             # blocks narrower on average are skipped as slivers
min_area = 50.0             # smaller blocks are skipped
origin = [24.94, 60.17]     # the local frame's origin (lon, lat); default: the data's

[per_side]                  # intervals every side (stage) of a block must meet
doors = [1, 4]
[per_block]                 # intervals over a whole block outline
balconies = [0, 80]

[setback]                   # centre line to facade, metres
default = 6.0
sidewalk = 2.5              # added to half a street's width (its width or lanes tag)
lane_width = 3.25
highway = { primary = 11.0, secondary = 9.5 }   # by highway class

[footprints]                # --footprints: building outlines re-skinned
stretch = 0.02              # a side may be met within this fraction (or slack)
tolerance = 0.5             # cleaning moves the outline at most this far (m)
storey_tolerance = 0        # storeys a building may differ from building:levels
storey_height = 3.3         # m: height / this when building:levels is missing
infill = true               # a flat roof over ground deeper than the parts reach
storeys.classic = { a = 4, b = 5, c = 3, d = 6 }   # storeys per facade family
roofs.classic = { gabled = ["a", "c", "d"], mansard = ["b"] }   # roof:shape -> families

[[zone]]                    # the first zone a block falls in wins
name = "waterfront"
polygon = [[24.945, 60.164], [24.953, 60.164], [24.953, 60.168], [24.945, 60.168]]
# or: highway = ["primary", "secondary"]   (blocks along such streets)
style = "modern"            # and optionally library, k, pick, per_side, per_block
kind = "perimeter"          # "perimeter" (facades round the block, the default), "row"
                            #   (complete buildings along each side) or "towers"

[[zone]]
name = "park towers"
highway = ["tertiary"]
kind = "towers"             # a tower per lot cut from the block
setback = 4.0               # row, towers: the block inset this far first (m; default 0)
lot = 36.0                  # towers: lots about this many metres square (default 36, <= 500)
height = [40, 90]           # towers: each tower's height in metres (required)
far = [2, 6]                # towers: floor area / lot area of each tower (required)
# style = "tower"           # towers: only a style set in the zone itself counts
```
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, get_args

from shapely.geometry import Polygon

from citysynth.pipeline.city.footprints import MAX_LEVELS, Storeys
from citysynth.pipeline.errors import MAX_K, MAX_STRETCH, ConfigError, shown
from citysynth.skeletons.degrees import in_degrees
from citysynth.skeletons.from_geometry import interval_problem, why_invalid
from citysynth.skeletons.geojson import MAX_VERTICES
from citysynth.skeletons.streets import NOT_STREETS, Setbacks
from citysynth.solver.problem import MAX_COST
from citysynth.solver.safe_read import read_toml

Pick = Literal["best", "vary"]   # which of a block's k layouts it keeps
PICKS: tuple[Pick, ...] = get_args(Pick)
Kind = Literal["perimeter", "row", "towers"]   # what a zone's street blocks become
KINDS: tuple[Kind, ...] = get_args(Kind)
LOT = 36.0            # m: a towers zone's default lot size

_Err = Callable[[str, str], ConfigError]   # (key, message) -> the error naming the file

__all__ = ["KINDS", "PICKS", "BuildSettings", "CityConfig", "ConfigError", "Kind", "Pick",
           "Zone", "ZoneKind", "load_config", "parse_config"]


@dataclass(frozen=True)
class BuildSettings:
    """What a block is built with; the top level of city.toml, or a zone's override."""

    library: str | None = None
    style: str | None = None
    k: int = 3
    pick: Pick = "vary"
    per_side: dict[str, tuple[float, float]] = field(default_factory=dict)
    per_block: dict[str, tuple[float, float]] = field(default_factory=dict)


@dataclass(frozen=True)
class ZoneKind:
    """A zone's ``kind`` and the keys only that kind reads. A street block of a
    ``"row"`` zone becomes complete buildings along each side, of a ``"towers"`` zone a
    tower per lot (:mod:`citysynth.pipeline.city.kinds`); ``"perimeter"`` blocks are
    facades round the block, as blocks outside any zone."""

    kind: Kind = "perimeter"
    setback: float = 0.0                        # row, towers: metres the block is inset
    lot: float = LOT                            # towers: lots about this many metres square
    height: tuple[float, float] = (0.0, 0.0)    # towers: metres
    far: tuple[float, float] = (0.0, 0.0)       # towers: floor area over lot area
    style: str | None = None                    # towers: the zone's own style, or any


@dataclass(frozen=True)
class Zone:
    name: str
    settings: BuildSettings
    polygon: tuple[tuple[float, float], ...] | None = None   # input coordinates
    highway: tuple[str, ...] = ()
    kind: ZoneKind = field(default_factory=ZoneKind)


@dataclass(frozen=True)
class FootprintSettings:
    """``[footprints]``: how building outlines are cleaned, stretched and storeyed."""

    stretch: float = 0.02
    tolerance: float = 0.5
    storeys: Storeys = field(default_factory=Storeys)
    infill: bool = True
    # what city.toml itself names: (key, style, family tag), checked against the
    # library once it is loaded (the defaults are the sample kit's and are not)
    named: tuple[tuple[str, str, str], ...] = ()


@dataclass(frozen=True)
class CityConfig:
    settings: BuildSettings = field(default_factory=BuildSettings)
    seed: int = 0
    stretch: float = 0.005
    corner_tolerance: float = 25.0
    mitre_cost: float = 10.0
    min_edge: float = 4.0
    min_width: float = 8.0
    min_area: float = 50.0
    origin: tuple[float, float] | None = None
    setbacks: Setbacks = field(default_factory=Setbacks)
    zones: tuple[Zone, ...] = ()
    path: Path | None = None
    slack: float = 0.3
    footprints: FootprintSettings = field(default_factory=FootprintSettings)
    not_streets: tuple[str, ...] = NOT_STREETS   # lines of the streets file left out


_SETTINGS = {"library", "style", "k", "pick", "per_side", "per_block"}
_TOP = _SETTINGS | {"seed", "stretch", "corner_tolerance", "mitre_cost", "min_edge",
                    "min_width", "min_area", "origin", "setback", "zone", "slack",
                    "footprints", "not_streets"}
_FOOTPRINTS = {"stretch", "tolerance", "storey_tolerance", "storey_height", "storeys", "infill",
               "roofs"}
_SETBACK = {"default", "sidewalk", "lane_width", "highway"}
_KIND_KEYS = {"setback": ("row", "towers"), "lot": ("towers",), "height": ("towers",),
              "far": ("towers",)}
_ZONE = _SETTINGS | {"name", "polygon", "highway", "kind"} | set(_KIND_KEYS)


def load_config(path: str | Path | None) -> CityConfig:
    """The config at ``path`` (None: all defaults)."""
    if path is None:
        return CityConfig()
    p = Path(path)
    return parse_config(read_toml(p, "city.toml", ConfigError), p)   # safe_read


def parse_config(data: dict, path: Path | None = None) -> CityConfig:
    """A validated :class:`CityConfig` from parsed TOML; the first bad key raises a
    :class:`ConfigError` naming it (``path`` names the file and anchors relative library
    folders)."""
    src = str(path) if path else "city.toml"

    def err(key: str, msg: str) -> ConfigError:
        return ConfigError(f"{src}: {key}: {msg}")

    _known(data, _TOP, "", err)
    base = path.parent if path else Path(".")
    settings = _settings(data, BuildSettings(), "", base, err)
    setbacks = _setbacks(data, err)
    zones = _zones(data, settings, base, err)
    origin = _origin(data, err)
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise err("seed", f"must be an integer, got {shown(seed)}")
    stretch = _pos(data, "stretch", 0.005, "", err, zero=True)
    if stretch > MAX_STRETCH:
        raise err("stretch", f"{stretch:g} would stretch parts by more than "
                             f"{100 * MAX_STRETCH:g} %; use at most {MAX_STRETCH:g}")
    return CityConfig(settings, seed, stretch,
                      _pos(data, "corner_tolerance", 25.0, "", err, zero=True,
                           most=MAX_CORNER_TOLERANCE),
                      _cost(data, "mitre_cost", 10.0, "", err),
                      _pos(data, "min_edge", 4.0, "", err, zero=True),
                      _pos(data, "min_width", 8.0, "", err, zero=True),
                      _pos(data, "min_area", 50.0, "", err, zero=True),
                      origin, setbacks, zones, path,
                      _slack(data, err), _footprints(data, err), _not_streets(data, err))


def _not_streets(data: dict, err: _Err) -> tuple[str, ...]:
    """``not_streets``: highway classes (``"footway"``) and tags (``"service=driveway"``)
    whose lines bound no block; [] keeps every line."""
    rules = data.get("not_streets", list(NOT_STREETS))
    if not isinstance(rules, list) or not all(
            isinstance(r, str) and r.strip() and not r.startswith("=") for r in rules):
        raise err("not_streets", 'must be a list of highway classes or tag=value, like '
                                 f'["footway", "service=driveway"], got {shown(rules)}')
    return tuple(rules)


def _slack(data: dict, err: _Err) -> float:
    slack = _pos(data, "slack", 0.3, "", err, zero=True)
    if slack > MAX_SLACK:
        raise err("slack", f"{slack:g} m would let a side be missed by more than "
                           f"{MAX_SLACK:g} m; use at most {MAX_SLACK:g}")
    return slack


def _footprints(data: dict, err: _Err) -> FootprintSettings:
    """``[footprints]``: stretch and cleaning tolerance, and the storey mapping (a
    style's table replaces the default one for that style)."""
    fp = data.get("footprints", {})
    if not isinstance(fp, dict):
        raise err("footprints", "must be a table")
    _known(fp, _FOOTPRINTS, "footprints.", err)
    stretch = _pos(fp, "stretch", 0.02, "footprints.", err, zero=True)
    if stretch > MAX_STRETCH:
        raise err("footprints.stretch", f"{stretch:g} would stretch parts by more than "
                                        f"{100 * MAX_STRETCH:g} %; use at most "
                                        f"{MAX_STRETCH:g}")
    tol = fp.get("storey_tolerance", 0)
    if isinstance(tol, bool) or not isinstance(tol, int) or tol < 0:
        raise err("footprints.storey_tolerance", f"must be a whole number >= 0, got {shown(tol)}")
    default = Storeys()
    fams = _style_tables(fp, "storeys", err, _storey_count)
    roofs = _style_tables(fp, "roofs", err, _family_list)
    storeys = Storeys(
        tol, _pos(fp, "storey_height", default.storey_height, "footprints.", err),
        _merged(default.families, fams), _merged(default.roofs, roofs))
    infill = fp.get("infill", True)
    if not isinstance(infill, bool):
        raise err("footprints.infill", f"must be true or false, got {shown(infill)}")
    named = tuple(sorted({(f"footprints.storeys.{st}.{tag}", st, tag)
                          for st, rows in fams.items() for tag, _n in rows}
                         | {(f"footprints.roofs.{st}.{roof}", st, tag)
                            for st, rows in roofs.items() for roof, tags in rows
                            for tag in tags}))
    return FootprintSettings(stretch, _pos(fp, "tolerance", 0.5, "footprints.", err,
                                           most=MAX_TOLERANCE),
                             storeys, infill, named)


def _storey_count(v: Any, key: str, err: _Err) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_LEVELS:
        raise err(key, f"must be a storey count (a whole number from 1 to {MAX_LEVELS}), "
                       f"got {shown(v)}")
    return v


def _family_list(v: Any, key: str, err: _Err) -> tuple[str, ...]:
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise err(key, f'must be a list of family tags like ["a", "c"], got {shown(v)}')
    return tuple(v)


def _style_tables(fp: dict, key: str, err: _Err, value: Callable[[Any, str, _Err], Any]
                  ) -> dict[str, list[tuple[str, Any]]]:
    """``footprints.<key>.<style> = { name = value }``, checked, by style."""
    raw = fp.get(key, {})
    if not isinstance(raw, dict) or not all(isinstance(t, dict) for t in raw.values()):
        raise err(f"footprints.{key}", "must be tables by style, like "
                  f"{key}.classic = {{ ... }}")
    return {style: [(str(n), value(v, f"footprints.{key}.{style}.{n}", err))
                    for n, v in table.items()] for style, table in raw.items()}


def _merged(default: tuple, given: dict[str, list[tuple[str, Any]]]) -> tuple:
    """The default rows but for the styles ``given`` replaces."""
    rows = [r for r in default if r[0] not in given]
    rows += [(style, n, v) for style, items in sorted(given.items()) for n, v in items]
    return tuple(rows)


def _setbacks(data: dict, err: _Err) -> Setbacks:
    sb = data.get("setback", {})
    if not isinstance(sb, dict):
        raise err("setback", "must be a table")
    _known(sb, _SETBACK, "setback.", err)
    table = sb.get("highway", {})
    if not isinstance(table, dict):
        raise err("setback.highway", "must be a table like { primary = 11.0 }")
    return Setbacks(
        _pos(sb, "default", 6.0, "setback.", err, most=MAX_SETBACK),
        _pos(sb, "sidewalk", 2.5, "setback.", err, zero=True, most=MAX_SETBACK),
        _pos(sb, "lane_width", 3.25, "setback.", err, most=MAX_SETBACK),
        tuple(sorted((str(c), _pos(table, c, 0, "setback.highway.", err, most=MAX_SETBACK))
                     for c in table)))


def _origin(data: dict, err: _Err) -> tuple[float, float] | None:
    origin = data.get("origin")
    if origin is None:
        return None
    if not isinstance(origin, list) or len(origin) != 2 or not all(_isnum(c) for c in origin):
        raise err("origin", "must be [lon, lat]")
    if not in_degrees(*origin):
        raise err("origin", f"must be [lon, lat] in degrees, got {origin}")
    return float(origin[0]), float(origin[1])


def _zones(data: dict, settings: BuildSettings, base: Path, err: _Err) -> tuple[Zone, ...]:
    raw = data.get("zone", [])
    if not isinstance(raw, list):
        raise err("zone", "must be an array of tables ([[zone]])")
    zones = tuple(_zone(z, i, settings, base, err) for i, z in enumerate(raw))
    first: dict[str, int] = {}
    for i, z in enumerate(zones):   # reports and blocks.geojson tell zones by name
        if z.name in first:
            raise err(f"zone[{i}].name", f"{shown(z.name)} names zone[{first[z.name]}] "
                                         "too; give each zone its own name")
        first[z.name] = i
    return zones


def _zone(z: Any, i: int, settings: BuildSettings, base: Path, err: _Err) -> Zone:
    """``[[zone]]`` number ``i``: a polygon and/or street classes, and the settings it
    overrides (inheriting the top level's)."""
    where = f"zone[{i}]."
    if not isinstance(z, dict):
        raise err(f"zone[{i}]", "must be a table")
    _known(z, _ZONE, where, err)
    name = z.get("name", f"zone {i}")
    if not isinstance(name, str) or not name.strip():
        raise err(where + "name", f"must be text, got {shown(name)}")
    poly = z.get("polygon")
    hw = z.get("highway", [])
    if poly is None and not hw:
        raise err(f"zone[{i}]", 'needs a polygon = [[lon, lat], ...] or highway = [...]')
    polygon = None if poly is None else _polygon(poly, where, err)
    if isinstance(hw, str):
        hw = [hw]
    if not isinstance(hw, list) or not all(isinstance(h, str) for h in hw):
        raise err(where + "highway", 'must be a list of highway classes, e.g. ["primary"]')
    return Zone(name, _settings(z, settings, where, base, err), polygon, tuple(hw),
                _zone_kind(z, name, where, err))


def _zone_kind(z: dict, name: str, where: str, err: _Err) -> ZoneKind:
    """The zone's ``kind`` and its keys; a key of another kind, a towers zone without
    its height or FAR, or an interval upside down names the zone and the key."""
    kind = z.get("kind", "perimeter")
    if kind not in KINDS:
        raise err(where + "kind", f"zone {name!r}: must be one of {', '.join(KINDS)}, "
                                  f"got {shown(kind)}")
    for key, kinds in _KIND_KEYS.items():
        if key in z and kind not in kinds:
            raise err(where + key, f"zone {name!r}: only a zone of kind "
                      f"{' or '.join(repr(k) for k in kinds)} reads it (this one is {kind!r})")
    if kind != "towers":
        return ZoneKind(kind, _pos(z, "setback", 0.0, where, err, zero=True,
                                   most=MAX_SETBACK))
    for key, what in (("height", "each tower's height in metres"),
                      ("far", "each tower's floor area over its lot's area")):
        if key not in z:
            raise err(where + key, f"zone {name!r}: a towers zone needs {key} = [min, max], "
                                   f"{what}")
    style = z.get("style")
    height = _positive_interval(z, "height", where, name, err)
    if height[1] > MAX_TOWER_HEIGHT:
        raise err(where + "height", f"zone {name!r}: towers of up to {height[1]:g} m; "
                  f"citysynth stacks towers of at most {MAX_TOWER_HEIGHT:,.0f} m")
    return ZoneKind(kind, _pos(z, "setback", 0.0, where, err, zero=True, most=MAX_SETBACK),
                    _pos(z, "lot", LOT, where, err, most=MAX_LOT), height,
                    _positive_interval(z, "far", where, name, err),
                    style if isinstance(style, str) else None)


def _positive_interval(z: dict, key: str, where: str, name: str, err: _Err
                       ) -> tuple[float, float]:
    iv = z[key]
    if (not isinstance(iv, list) or len(iv) != 2 or not all(_isnum(x) for x in iv)
            or not 0 < iv[0] <= iv[1]):
        raise err(where + key, f"zone {name!r}: must be [min, max] with 0 < min <= max, "
                               f"got {shown(iv)}")
    return float(iv[0]), float(iv[1])


def _polygon(poly: Any, where: str, err: _Err) -> tuple[tuple[float, float], ...]:
    if (not isinstance(poly, list) or len(poly) < 3 or not all(
            isinstance(q, list) and len(q) == 2 and all(_isnum(c) for c in q)
            for q in poly)):
        raise err(where + "polygon", "must be a list of at least 3 [lon, lat] pairs")
    if len(poly) > MAX_VERTICES:   # else refused on the way, as "feature 0" of a file
        raise err(where + "polygon", f"{len(poly):,} points, more than the "
                  f"{MAX_VERTICES:,} a zone's polygon may have; a zone's edge need not "
                  "follow every kerb: give fewer points")
    if not Polygon(poly).is_valid:
        what, fix = why_invalid(Polygon(poly), None)
        raise err(where + "polygon", f"not a valid polygon ({what}); {fix}")
    return tuple((float(a), float(b)) for a, b in poly)


def _isnum(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _known(d: dict, allowed: set[str], prefix: str, err: _Err) -> None:
    for k in d:
        if k not in allowed:
            raise err(prefix + k, f"unknown key (known: {', '.join(sorted(allowed))})")


MAX_CORNER_TOLERANCE = 90.0   # degrees a corner part may be bent: more is another corner
MAX_TOLERANCE = 10.0       # metres footprint cleaning may move an outline: more is not it
MAX_SETBACK = 500.0        # metres from a centre line (or a zone's edge) to the facades:
                           # more is no street (1e300 overflowed GEOS's buffer)
MAX_LOT = 500.0            # metres square a towers zone's lot may be: more is a block,
                           # and lot = 1e9 was refused as a floor-area ratio of 1.5e-14
MAX_SLACK = 2.0            # metres a side may be missed by: more would leave gaps visibly
MAX_TOWER_HEIGHT = 1000.0  # metres: the tallest building stands 828 m; a tower of a km
                           # or more is a typo, and its search would run for minutes


def _pos(d: dict, key: str, default: float, prefix: str, err: _Err, *,
         zero: bool = False, most: float | None = None) -> float:
    v = d.get(key, default)
    if not _isnum(v) or v < 0 or (v == 0 and not zero):
        raise err(prefix + key, f"must be a {'non-negative' if zero else 'positive'} number, "
                                f"got {shown(v)}")
    if most is not None and v > most:
        raise err(prefix + key, f"must be at most {most:g}, got {shown(v)}")
    return float(v)


def _cost(d: dict, key: str, default: float, prefix: str, err: _Err) -> float:
    """A key that becomes a solver cost (``mitre_cost``): non-negative and at most the
    solver's :data:`~citysynth.solver.problem.MAX_COST`, as a problem file's costs (1e308
    was taken, then summed to infinity, and every footprint with a mitre failed as if its
    sides could not be met together: "allow more stretch")."""
    v = _pos(d, key, default, prefix, err, zero=True)
    if v > MAX_COST:
        raise err(prefix + key, f"must be at most {MAX_COST:g} (a cost this large sums to "
                                f"infinity), got {shown(v)}; the default is {default:g}")
    return v


def _intervals(d: Any, key: str, err: _Err) -> dict[str, tuple[float, float]]:
    if not isinstance(d, dict):
        raise err(key, 'must be a table like { doors = [1, 3] }')
    out = {}
    for name, iv in d.items():
        problem = interval_problem(iv, "block")
        if problem:
            raise err(f"{key}.{name}", problem)
        out[str(name)] = (float(iv[0]), float(iv[1]))
    return out


def _settings(d: dict, inherit: BuildSettings, prefix: str, base: Path,
              err: _Err) -> BuildSettings:
    s = inherit
    if "library" in d:
        if not isinstance(d["library"], str):
            raise err(prefix + "library", "must be a folder path")
        s = replace(s, library=str((base / d["library"]).resolve()))
    if "style" in d:
        if not isinstance(d["style"], str):
            raise err(prefix + "style", "must be a style name")
        s = replace(s, style=d["style"])
    if "k" in d:
        k = d["k"]
        if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= MAX_K:
            raise err(prefix + "k", f"must be an integer from 1 to {MAX_K}, got {shown(k)}")
        s = replace(s, k=k)
    if "pick" in d:
        if d["pick"] not in PICKS:
            raise err(prefix + "pick", f"must be one of {', '.join(PICKS)}, got {shown(d['pick'])}")
        s = replace(s, pick=d["pick"])
    if "per_side" in d:
        s = replace(s, per_side=_intervals(d["per_side"], prefix + "per_side", err))
    if "per_block" in d:
        s = replace(s, per_block=_intervals(d["per_block"], prefix + "per_block", err))
    return s
