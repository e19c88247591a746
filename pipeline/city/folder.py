"""The names of the files a city run writes into its folder.

A module of its own, importing nothing of the project at its top, so what reads a
run folder (``citysynth diff``) need not load what writes one.
"""

from pathlib import Path

BLOCKS_DIR = "blocks"              # a block's layout JSON, USD and cuts: blocks/<id>*
MANIFEST = "manifest.json"         # every block's inputs hash, status, files and cost
BLOCKS_GEOJSON = "blocks.geojson"  # every block's outline with its status, for a GIS
REPORT = "report.json"             # counts, timings, failures and errors of the run
RUN_SCHEMA = "citysynth.run"       # the manifest's "schema"
RUN_VERSION = 1                    # ... and its "version", which diff reads
CITY_FILES = ("city.usda", "city.png", "city.glb")   # the city stage, overview, one GLB
MARKER = ".done.json"              # blocks/<id>.done.json: a block finished, its hashes


def misplaced(out: str) -> str | None:
    """What in an existing run folder ``out`` stands where the run writes something of
    another kind (a file named ``blocks``, a folder named ``manifest.json``): said
    before any block is solved, where the run found it only when writing, after every
    block's work. None when nothing does."""
    import os

    from citysynth.export.usd import MATERIALS_DIR, PARTS_DIR

    root = Path(out)
    blocks = root / BLOCKS_DIR
    for folder, what in ((blocks, "its blocks folder"),
                         (blocks / PARTS_DIR, "the part files its blocks share"),
                         (blocks / PARTS_DIR / MATERIALS_DIR, "their materials")):
        if os.path.islink(folder) and not folder.exists():   # a loop, or leads nowhere
            return (f"{folder}: a link that leads to no folder where the run keeps "
                    f"{what}; remove the link, or give another -o folder")
        if folder.exists() and not folder.is_dir():
            return (f"{folder}: a file where the run keeps {what}; move it away, or "
                    "give another -o folder")
    for name in (MANIFEST, BLOCKS_GEOJSON, REPORT, *CITY_FILES):
        if (root / name).is_dir():
            return (f"{root / name}: a folder where the run writes its {name} file; move "
                    "it away, or give another -o folder")
    return None


def not_a_run(out: str) -> str | None:
    """What in an existing folder ``out`` that is not a citysynth run the run would
    write over: a ``manifest.json`` of something else (a web app's), or, with no
    manifest, a file by one of the names the run writes (its ``report.json``, a
    ``city.png``). Said before anything is written: such a folder lost its file without
    a word. A run's own folder always has its manifest once it holds any of them (the
    manifest is written first), and a first run killed before it holds none. None when
    the run may write there."""
    from citysynth.pipeline.errors import UsageError
    from citysynth.solver.safe_read import read_json

    root = Path(out)
    manifest = root / MANIFEST
    fix = "give a new or empty -o folder, or the folder of an earlier citysynth city run"
    if manifest.is_file():
        try:
            data = read_json(manifest, "manifest", UsageError)
        except UsageError:
            data = None
        if not (isinstance(data, dict) and data.get("schema") == RUN_SCHEMA):
            return (f"{manifest}: not the manifest of a citysynth city run, and the run "
                    f"would write its own over it; {fix}")
        return None
    ours = [n for n in (REPORT, BLOCKS_GEOJSON, *CITY_FILES) if (root / n).is_file()]
    if ours:
        return (f"{root}: not the folder of a citysynth city run (it has no {MANIFEST}), "
                f"and the run would write over its {', '.join(ours)}; {fix}")
    return None


def input_in_outputs(out: str, inputs: "list[str | None]") -> str | None:
    """What input file (``FILE`` or ``FILE::LAYER``) is one the run writes in ``out``:
    ``--footprints run/blocks.geojson -o run`` replaced the user's file with the run's
    own and exited 0 (the next run built from its own output). None when none is."""
    from citysynth.skeletons.gis_files import split_layer

    for text in filter(None, inputs):
        given = Path(split_layer(text)[0])
        mine = run_file(out, given) if given.is_file() else None
        if mine == BLOCKS_DIR:
            return (f"{text}: this input file is in the run's {BLOCKS_DIR} folder, which "
                    "the run rewrites; copy it out of the run folder, or give another "
                    "-o folder")
        if mine is not None:
            return (f"{text}: the run writes its {mine} over this input file; "
                    "copy the input out of the run folder, or give another -o folder")
    return None


def run_file(run: str | Path, path: str | Path) -> str | None:
    """Which of the run folder ``run``'s own files ``path`` is (by any name: a link, a
    hard link, ``./``): the file's name (``manifest.json``), or ``blocks`` for
    anything in its blocks folder, which the run rewrites; None when it is none. Both
    an input the run would write over and an output another command (``diff --png``)
    would write into a run are refused with it."""
    from citysynth.pipeline.paths import written_over

    root, given = Path(run), Path(path)
    hit = written_over([root / n for n in (MANIFEST, BLOCKS_GEOJSON, REPORT, *CITY_FILES)],
                       [given])
    if hit is not None:
        return hit[0].name
    blocks = root / BLOCKS_DIR
    if blocks.is_dir() and given.resolve().is_relative_to(blocks.resolve()):
        return BLOCKS_DIR
    return None
