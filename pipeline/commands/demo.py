"""``citysynth demo [-o DIR]``: the embedded demo, runnable with no user data.

Three steps, each a real use of the tool on files shipped in ``examples/``:

1. the solver alone: an 83.4 m street front filled exactly with complete buildings,
   the three best layouts printed as to-scale strips;
2. a T-shaped building (``examples/skeletons/t_building.geojson``) in the classic style
   and a city block with a cut corner and a notch (``examples/blocks/block.geojson``)
   in the modern style, with the sample part library: layout JSON, USD, GLB and a PNG
   preview each;
3. a city: a district of central Helsinki (OpenStreetMap street centre lines, 26
   irregular blocks) built with ``examples/city/city.toml``: ``city.usda`` (checked with
   every UsdValidation validator), the overview ``city.png``, and per-block layout JSON
   and USD in ``blocks/``.
"""

from __future__ import annotations

from pathlib import Path

from citysynth import examples
from citysynth.export.errors import ExportError
from citysynth.pipeline.city.process import cpu_count
from citysynth.pipeline.commands.city import report_bugs
from citysynth.pipeline.commands.results_text import format_result

DEMO_LENGTH_M = 83.4
DEMO_K = 3
EXAMPLES = examples.ROOT
DISTRICT = EXAMPLES / "city" / "district_streets.geojson"
CITY_CONFIG = EXAMPLES / "city" / "city.toml"


def register(sub) -> None:
    p = sub.add_parser("demo", help="run the embedded demo (no user data needed)",
                       description="Solve the sample street front, build the sample "
                                   "T-shaped building and city block with the sample library, "
                                   "then a district of central Helsinki; USD, GLB, PNG and "
                                   "layout JSON go to DIR.")
    p.add_argument("-o", "--out", default="out", metavar="DIR",
                   help="output folder (default: out/)")
    p.set_defaults(run=run)


def strip(sequence: list[str], widths: dict[str, float], scale: float = 1.0) -> str:
    """A to-scale text strip: one cell per building, 1 character per metre."""
    cells = []
    for b in sequence:
        w = max(int(round(widths[b] / scale)), 3)
        label = f"{widths[b]:g}"
        cells.append(label.center(w - 1, "-")[: w - 1])
    return "|" + "|".join(cells) + "|"


def street_front_step() -> int:
    from citysynth.solver import Problem, solve  # numba: when run (see pipeline.cli)
    from citysynth.solver.samples import street_front

    problem = Problem.from_dict(street_front(DEMO_LENGTH_M, k=DEMO_K))
    result = solve(problem)
    print(f"1. a {DEMO_LENGTH_M} m street front from {len(problem.elements)} complete "
          "buildings (4-20 m, 0.2 m grid)\n")
    print(format_result(result))
    widths = {e.id: e.resources["length"] for e in problem.elements}
    print("\nto scale (1 character = 1 m, widths in m):")
    for i, sol in enumerate(result.solutions, 1):
        print(f"#{i} {strip(sol.sequence, widths)}")
    return 0 if result.status == "ok" else 1


def run(args) -> int:
    from citysynth.export.usd import validate  # when run (see pipeline.cli)
    from citysynth.parts_db import load_library
    from citysynth.parts_db.files import all_or_nothing
    from citysynth.pipeline.city.config import load_config
    from citysynth.pipeline.city.outputs import finish_city
    from citysynth.pipeline.city.run import prepare, progress_printer, run_city
    from citysynth.pipeline.layouts import solve_layouts, summary_line, write_outputs
    from citysynth.skeletons import read_geojson, skeleton_from_lines, skeletons_from_polygons

    status = street_front_step()
    out = Path(args.out)
    db = load_library(EXAMPLES / "library")
    feats, frame = read_geojson(EXAMPLES / "skeletons" / "t_building.geojson")
    building = solve_layouts("t_building", [skeleton_from_lines(feats, frame, "t_building")],
                             db, "classic", k=DEMO_K)
    feats, frame = read_geojson(EXAMPLES / "blocks" / "block.geojson")
    block = solve_layouts("block", skeletons_from_polygons(feats, frame), db, "modern", k=1)
    print(f"\n2. a T-shaped building (classic, k={DEMO_K}) and a city block (modern) from "
          f"the sample library ({len(db.parts)} parts), to {out}/")
    for built in (building, block):
        if built.status != "ok":
            raise ExportError(f"demo: {built.name} is infeasible: {built.reason}")
        with all_or_nothing(out):   # a disk that fills leaves no half of a building
            paths = write_outputs(built, db, out)
        print(f"{built.name}: wrote {len(paths)} files")
        for lay in built.layouts:
            print("  " + summary_line(lay))
    print(f"\n3. a district of central Helsinki ({DISTRICT.name}, OpenStreetMap) with "
          f"{CITY_CONFIG.name}, to {out}/")
    cfg = load_config(CITY_CONFIG)
    inputs = prepare(DISTRICT, None, cfg, None)
    report = run_city(inputs, out, workers=cpu_count(),
                      progress=progress_printer(pieces=len(inputs.skipped)))
    city, png = finish_city(inputs, report, out)
    errors = validate(city)
    c = report["counts"]
    kinds = ", ".join(f"{v.get('built', 0)} {k}" for k, v in report["kinds"].items())
    print(f"{c['built']} blocks built ({kinds}), {c['failed']} failed, {c['skipped']} pieces "
          f"skipped; "
          f"wrote {city} (UsdValidation: {'clean' if not errors else f'{len(errors)} errors'})"
          f" and {png}")
    for e in errors:
        print(f"  {e}")
    return report_bugs(report, "citysynth demo") or (1 if errors else status)
