"""Skeletons + a part library -> checked layouts -> files: the one path every command
that makes geometry takes (``building``, ``block``, ``demo``, and the city run).

:func:`solve_layouts` turns the skeletons of one building or block into its k best
layouts (each skeleton is solved on its own; a block's courtyard ring does not
constrain its outer ring, so the i-th layout combines every ring's i-th solution, or
its last when it has fewer). :func:`write_outputs` writes, for each layout, the layout
JSON, the USD layer, the GLB and the PNG preview, every file atomically, and the
shared part prototypes once; with k > 1 also ``<name>.usda``, the k layers as the
variants of one ``layout`` variantSet (a city block carries it too: see
:mod:`~citysynth.pipeline.city.jobs`).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from citysynth.export.assemble import extent
from citysynth.export.infill import Roof
from citysynth.export.layout import Layout
from citysynth.export.party import Segment
from citysynth.export.place import layout, max_stretch
from citysynth.export.usd import write_variants
from citysynth.export.writers import BESIDE, FORMATS, SUFFIX, Format, write_ranks
from citysynth.parts_db import PartDB
from citysynth.pipeline.errors import UsageError, shown
from citysynth.pipeline.paths import written_over
from citysynth.pipeline.skeleton_to_structure import skeleton_structure
from citysynth.skeletons import Skeleton
from citysynth.solver.diagnose import nearest
from citysynth.solver.errors import TooLargeError
from citysynth.solver.methods import DEFAULT_MAX_MEMORY_MB
from citysynth.solver.structures import solve_structure
from citysynth.solver.structures.blocked import Blocked

BlockedAt = tuple[str, Blocked]
"""The skeleton (by name) a failed building or block is blocked on, and the stage there
its reason names: what messages locate as a side, in the input's coordinates."""


@dataclass
class Built:
    """The outcome for one building or block."""

    name: str
    status: str                         # "ok" or "infeasible"
    layouts: list[Layout] = field(default_factory=list)
    reason: str | None = None
    timings: dict[str, float] = field(default_factory=dict)
    blocked_at: BlockedAt | None = None   # when the reason names a stage of a skeleton


def default_style(db: PartDB) -> str:
    styles = sorted({p.style for p in db.select("middle")})
    if not styles:
        raise UsageError(f"the library {db.name!r} has no middle parts to fill facades")
    return styles[0]


def check_style(db: PartDB, style: str) -> None:
    styles = sorted({p.style for p in db.select("middle")})
    if style not in styles:
        raise UsageError(f"the library {db.name!r} has no style {shown(style)}; it has "
                            f"{', '.join(styles)}")


def too_large(name: str, skeletons: list[Skeleton], exc: TooLargeError,
              wide: Sequence[str] = ()) -> str:
    """A building or block too large to solve, in its user's words: how much facade,
    its longest side, what solving it would take against the budget, what to do (the
    solver's own text speaks of stage graphs, states and quanta; its figures ride on
    the error). ``wide``: the resources of its per-block intervals, which make a long
    facade far dearer (the first thing to loosen)."""
    if exc.k is not None:
        return (f"{name}: k = {exc.k:,} layouts would take at least "
                f"{(exc.need_mb or 0) / 1024:,.1f} GB to keep, over the "
                f"{exc.budget_mb or 0:,.0f} MB budget; ask for fewer (--k)")
    if exc.shares is not None:
        return (f"{name}: its per-block intervals on {', '.join(exc.resources)} leave "
                f"{exc.shares:,} ways to share the totals between its sides, too many "
                "to solve; narrow them")
    total = sum(e.length for sk in skeletons for e in sk.edges)
    longest = max((e.length for sk in skeletons for e in sk.edges), default=0.0)
    cost = (f" would take about {exc.need_mb:,.0f} MB to solve" if exc.need_mb is not None
            else " would take too much memory to solve") + \
        (f", over the {exc.budget_mb:,.0f} MB budget" if exc.budget_mb is not None else "")
    fix = (f"narrow or drop its per-block intervals on {', '.join(wide)}, or split it"
           if wide else "split it into smaller blocks or buildings")
    return (f"{name}: too large to lay out: {total:,.0f} m of facade (its longest side "
            f"{longest:,.0f} m){cost}; {fix}")


LAYOUT_MB_PER_KM = 15.0
"""Memory a building or block takes per km of facade, solved, laid out and written
(measured: a 100 km square block, 400 km of facade, peaked at 5.9 GB)."""


def check_facade(name: str, skeletons: list[Skeleton]) -> None:
    """Refuse, before anything is solved, a building or block whose facade would take
    more than the memory budget to lay out (a 100 km square ran for five minutes)."""
    need = sum(e.length for sk in skeletons for e in sk.edges) / 1000 * LAYOUT_MB_PER_KM
    if need > DEFAULT_MAX_MEMORY_MB:
        raise TooLargeError(too_large(name, skeletons, TooLargeError(
            "", need_mb=need, budget_mb=DEFAULT_MAX_MEMORY_MB)), need_mb=need,
            budget_mb=DEFAULT_MAX_MEMORY_MB)


def _with_alone(blocked: Blocked, alone: dict[int, tuple[float, ...]]) -> Blocked:
    """``blocked`` with the lengths its stage's two T parts span alone (``alone``, when
    the pipeline asked that stage for a middle part) among the nearest lengths its
    diagnosis names: a 10.3 m bar between two T parts was told "the nearest they make
    there is 14.00 m", though a 10.4 m one builds with the T parts alone."""
    spans = alone.get(blocked.stage)
    if not spans:
        return blocked
    details = []
    for d in blocked.details:
        if d["constraint"] == "length":
            lo, hi = d["asked"]
            mid = (lo + hi) / 2
            made = [*nearest(d), *spans]
            d = {**d, "nearest_below": max((x for x in made if x < mid), default=None),
                 "nearest_above": min((x for x in made if x > mid), default=None)}
        details.append(d)
    return replace(blocked, details=details)


def solve_layouts(name: str, skeletons: list[Skeleton], db: PartDB, style: str,
                  k: int = 1, *, infill: Roof = "pockets", party: Sequence[Segment] = (),
                  label: str | None = None, **options) -> Built:
    """The k best layouts of one building or block (checked; see module docstring),
    each with its roof infill as ``infill`` says (``all`` for a footprint, ``pockets``
    for a street block: see :mod:`~citysynth.export.infill`) and its parts stopped at
    the ``party`` walls it shares with neighbours (:mod:`~citysynth.export.party`).
    ``options`` go to
    :func:`~citysynth.pipeline.skeleton_to_structure.skeleton_structure` (corner
    tolerance, mitres, stretch, per-side and per-structure constraints). ``label``:
    how a refusal names it to its user (the file and feature it came from), if not by
    ``name``, its output files' stem."""
    check_style(db, style)
    check_facade(label or name, skeletons)
    t0 = time.perf_counter()
    plans = [skeleton_structure(sk, db, style, k=k, **options) for sk in skeletons]
    t1 = time.perf_counter()
    try:
        results = [solve_structure(p.structure, k) for p in plans]
    except TooLargeError as exc:
        raise TooLargeError(too_large(label or name, skeletons, exc,
                                      sorted(options.get("per_structure") or {})),
                            need_mb=exc.need_mb,
                            budget_mb=exc.budget_mb, shares=exc.shares,
                            resources=exc.resources, k=exc.k) from None
    t2 = time.perf_counter()
    timings = {"structure_s": t1 - t0, "solve_s": t2 - t1}
    for sk, p, r in zip(skeletons, plans, results, strict=True):
        if r.status != "ok":
            return Built(name, "infeasible", reason=f"{sk.name}: {r.reason}", timings=timings,
                         blocked_at=(sk.name, _with_alone(r.blocked, p.alone))
                         if r.blocked else None)
    count = max(len(r.solutions) for r in results)
    placements = [p.placement for p in plans]
    layouts = [layout(name, i + 1, placements,
                      [r.solutions[min(i, len(r.solutions) - 1)] for r in results], db,
                      infill, party)
               for i in range(count)]
    timings["layout_s"] = time.perf_counter() - t2
    return Built(name, "ok", layouts, timings=timings)


def output_stem(lay: Layout, k: int) -> str:
    """``name`` for a single result, ``name_<rank>`` when there are several."""
    return lay.name if k == 1 else f"{lay.name}_{lay.rank}"


def chosen_formats(preview: bool) -> list[Format]:
    """Every output format, or all but the PNG preview (a command's --no-preview)."""
    return [f for f in FORMATS if preview or f != "png"]


def write_outputs(built: Built, db: PartDB, out_dir: str | Path, *,
                  formats: Sequence[Format] = FORMATS, k: int | None = None,
                  selected: int = 1, inputs: Sequence[str | Path] = ()) -> list[Path]:
    """Write each layout of ``built`` in ``formats`` to ``out_dir``; the file paths.
    Export and preview times add up in ``built.timings``. With several layouts the
    variant stage selects rank ``selected`` (a city block: the one its run picked).
    None of the files may be one of ``inputs`` (the command's input files)."""
    out = Path(out_dir)
    k = len(built.layouts) if k is None else k
    paths = []
    stems = [out / output_stem(lay, k) for lay in built.layouts]
    if inputs and built.layouts:
        _check_not_inputs([*stems, out / built.layouts[0].name], formats, inputs)
    for fmt in formats:
        t = time.perf_counter()
        paths.extend(write_ranks(built.layouts, db, stems, fmt))
        key = "preview_s" if fmt == "png" else "export_s"
        built.timings[key] = built.timings.get(key, 0.0) + time.perf_counter() - t
    if "usd" in formats and k > 1 and built.layouts:
        paths.append(write_variant_stage(built.layouts, db, out, k, selected))
    if built.layouts:
        _sweep_stale(out, built.layouts[0].name, formats, paths)
    return paths


def _check_not_inputs(stems: Sequence[Path], formats: Sequence[Format],
                      inputs: Sequence[str | Path]) -> None:
    """Refuse to write over an input file: ``street --line out/ok.layout.usda -o out``
    replaced the street line with the USD it made from it, and exited 0."""
    suffixes = [x for f in formats for x in (SUFFIX[f], *BESIDE.get(f, ()))]
    hit = written_over((Path(f"{stem}{x}") for stem in stems for x in suffixes),
                       [Path(i) for i in inputs])
    if hit is not None:
        raise UsageError(f"{hit[1]}: the output {hit[0].name} would overwrite this input "
                         "file; write to another folder (-o) or rename the input")


def _sweep_stale(out: Path, name: str, formats: Sequence[Format], written: list[Path]
                 ) -> None:
    """Remove what an earlier run of the same layout name left in ``out`` in these
    formats and this run did not write (``name_3.*`` after k = 3 then k = 1, ``name.glb``
    after k = 1 then k = 3), so a folder never holds results of two runs side by side.
    A ``name_<r>`` file is this layout's only when ``name_<r>.layout.json`` says so (a
    building may be called ``name_2`` itself)."""
    keep = {p.resolve() for p in written}
    suffixes = [x for f in formats for x in (*BESIDE.get(f, ()), SUFFIX[f])]
    stale = [p for p in (out / f"{name}{x}" for x in suffixes) if p.is_file()]
    for rank, files in ranked_files(out, name, [*suffixes, SUFFIX["json"]]):
        if _rank_of(out / f"{name}_{rank}{SUFFIX['json']}", name) == rank:
            stale += [p for p in files if p.name.endswith(tuple(suffixes))]
    stale = [p for p in stale if p.resolve() not in keep]
    for p in stale:   # after reading every layout JSON that tells whose a file is
        p.unlink(missing_ok=True)


def ranked_files(out: Path, name: str, suffixes: Sequence[str]
                 ) -> list[tuple[int, list[Path]]]:
    """The files ``name_<rank><suffix>`` in ``out``, by rank: every rank up to
    :data:`PROBED_RANKS` (so a rank deleted by hand hides none after it), then on while
    a rank has any. Names are tried, not listed: a city folder holds tens of thousands
    of files, and listing it for each of its blocks was quadratic."""
    out_ranks: list[tuple[int, list[Path]]] = []
    base, kinds = os.path.join(out, f"{name}_"), list(dict.fromkeys(suffixes))
    rank = 1
    while True:
        files = [Path(f) for f in (f"{base}{rank}{x}" for x in kinds) if os.path.isfile(f)]
        if files:
            out_ranks.append((rank, files))
        elif rank >= PROBED_RANKS:
            return out_ranks
        rank += 1


PROBED_RANKS = 100   # a city's largest k; about 0.2 ms of file checks a block


def _rank_of(layout_json: Path, name: str) -> int | None:
    """The rank a layout JSON holds when it is a layout named ``name``."""
    try:
        d = json.loads(layout_json.read_text())
    except (OSError, ValueError):
        return None
    return d.get("rank") if isinstance(d, dict) and d.get("name") == name else None


def write_variant_stage(layouts: Sequence[Layout], db: PartDB, out: Path, k: int,
                        selected: int = 1) -> Path:
    """``<name>.usda``: the layouts' layers (``<name>_<rank>.usda``, written before,
    ``k`` asked) as one prim with a ``layout`` variantSet, ``rank_<selected>`` selected,
    its ``extentsHint`` the box around them all (whichever rank is picked)."""
    name = layouts[0].name
    ranks = [(lay.rank, f"{output_stem(lay, k)}{SUFFIX['usd']}") for lay in layouts]
    return write_variants(out / f"{name}{SUFFIX['usd']}", name, ranks, selected,
                          extent(layouts, db))


def summary_line(lay: Layout) -> str:
    return (f"#{lay.rank}  cost {round(lay.cost, 6):g}  {len(lay.instances)} parts "
            f"({len(lay.parts_used())} distinct)  stretch ≤ {100 * max_stretch(lay):.2f} %")
