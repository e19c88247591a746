"""``citysynth diff RUN_A RUN_B [--json]``: compare two city runs, block by block.

Layout JSON and USD are byte-identical for identical inputs, so "changed" is exact: a
block changed when its layout file differs. For each changed block the diff gives the
cost delta, the resources met that moved (per structure and stage) and the parts that
differ; blocks added, removed or whose status changed are listed too, and blocks one
run drew in the same place as the other under a new id (:mod:`.diff_places`). A block whose
kept layout is the same can still look different: another of its k layouts changed,
or the geometry of the parts cut or sheared at its joints (an export change). Those blocks are
listed with the files that differ, so a regression shows even when no layout moved.
Exit 0 when the runs are identical, 1 when not, 2 when a folder is not a run.
"""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path
from typing import Any

from citysynth.pipeline.city.folder import BLOCKS_DIR, MANIFEST, MARKER, RUN_SCHEMA, RUN_VERSION
from citysynth.pipeline.commands.diff_places import same_places
from citysynth.pipeline.errors import UsageError
from citysynth.solver.safe_read import decode, parse_json, read_bytes, read_json, shown


def register(sub) -> None:
    p = sub.add_parser("diff", help="compare two city runs",
                       description="Compare the blocks of two run folders (written by "
                                   "citysynth city): which layouts changed, cost deltas, "
                                   "constraint values, blocks whose other files (another of "
                                   "the k layouts, the cut geometry) differ, blocks added or "
                                   "removed, blocks drawn in the same place under a new id "
                                   "(renamed). Exit 0 when identical, 1 when not.")
    p.add_argument("run_a", metavar="RUN_A")
    p.add_argument("run_b", metavar="RUN_B")
    p.add_argument("--json", action="store_true", help="print the differences as JSON")
    p.add_argument("--png", metavar="FILE", help="also draw the diff as a plan: every "
                   "block's outline coloured by what changed")
    p.set_defaults(run=run)


# a block record's status, as pipeline.city.jobs.BlockStatus (not imported: diff loads
# no geometry library; tests/test_city_outputs.py keeps the two the same)
STATUSES = ("built", "failed", "skipped", "error")


def _manifest(run: Path) -> dict:
    """The run's manifest, checked for the shape :mod:`..city.outputs` writes."""
    if not run.exists():
        raise UsageError(f"{run}: no such folder; give the -o folder of citysynth city")
    if not run.is_dir():
        raise UsageError(f"{run}: not a folder; give the -o folder of citysynth city")
    if not (run / MANIFEST).exists():
        if markers := _markers(run):
            raise UsageError(f"{run}: a citysynth city run stopped here before it finished "
                             f"({len(markers)} blocks built, no {MANIFEST} yet); run the "
                             f"same citysynth city into {run} again to finish it, then "
                             "compare")
        raise UsageError(f"{run}: not a citysynth run folder (no {MANIFEST}); give the "
                         "-o folder of citysynth city")
    where = run / MANIFEST
    if not where.resolve().is_relative_to(run.resolve()):   # a link out of the folder
        raise UsageError(f"{where}: a link to {where.resolve()}, outside the run folder; "
                         "diff reads only what a run wrote: give the -o folder of "
                         "citysynth city itself")
    m = read_json(where, "run manifest", UsageError)
    if not isinstance(m, dict) or m.get("schema") != RUN_SCHEMA:
        raise UsageError(f"{where}: not a {RUN_SCHEMA} manifest; rerun citysynth city "
                         f"into {run}")
    version = m.get("version")
    if version != RUN_VERSION or isinstance(version, bool):
        raise UsageError(f"{where}: a run manifest of version {shown(version)}, which this "
                         f"citysynth does not read (it writes and reads version "
                         f"{RUN_VERSION}); rerun citysynth city into {run}")
    blocks = m.get("blocks")
    if not isinstance(blocks, dict) or not all(isinstance(r, dict) and isinstance(
            r.get("files", []), list) and all(isinstance(f, str) for f in r.get("files", []))
            for r in blocks.values()):
        raise UsageError(f"{where}: \"blocks\" is not an object of block records; rerun "
                         f"citysynth city into {run}")
    for bid, r in sorted(blocks.items()):
        rank = r.get("rank")
        if rank is not None and (isinstance(rank, bool) or not isinstance(rank, int)):
            raise UsageError(f"{where}: block {bid} has rank {shown(rank)}, which citysynth "
                             f"city never writes (a rank is a whole number); rerun "
                             f"citysynth city into {run}")
        cost = r.get("cost")
        if r.get("status") not in STATUSES or (cost is not None and (
                isinstance(cost, bool) or not isinstance(cost, int | float))):
            raise UsageError(f"{where}: block {bid} has status {r.get('status')!r} and cost "
                             f"{cost!r}, which citysynth city never writes (a status is "
                             f"one of {', '.join(STATUSES)}, a cost a number); rerun "
                             f"citysynth city into {run}")
    return m


def _markers(run: Path) -> dict[str, Path]:
    """The blocks a run finished in ``run`` (their markers), by id."""
    folder = run / BLOCKS_DIR
    if not folder.is_dir():
        return {}
    return {p.name[: -len(MARKER)]: p for p in folder.glob(f"*{MARKER}")}


def built_after(run: Path, blocks: dict) -> int:
    """How many blocks of ``run`` a later run finished after the manifest was written
    (a run stopped before its end: the manifest still tells the run before): markers
    of blocks the manifest lacks, or of other inputs than it records."""
    later = 0
    for bid, path in _markers(run).items():
        rec = blocks.get(bid)
        if rec is None:
            later += 1
            continue
        try:
            marker = json.loads(path.read_bytes())
        except (OSError, ValueError):
            continue   # a damaged marker: the next run builds the block again
        if isinstance(marker, dict) and marker.get("input_hash") != rec.get("input_hash"):
            later += 1
    return later


def _inside(run: Path, bid: str, f: str) -> Path:
    """The path of file ``f`` a block's record names, refused outside ``run``."""
    path = (run / f).resolve()
    if not path.is_relative_to(run.resolve()) or Path(f).is_absolute():
        raise UsageError(f"{run / MANIFEST}: block {bid} names {f!r}, outside the run "
                         "folder; the manifest is not citysynth's")
    if path.is_dir():
        raise UsageError(f"{path}: a folder, where the run's manifest names a block's "
                         "file; the manifest is not citysynth's")
    return path


def _layout(run: Path, bid: str, rec: dict) -> tuple[str, Path, bytes] | None:
    """A block's layout file: its name in the record, its path (only inside ``run``)
    and its bytes."""
    f = next((f for f in rec.get("files", []) if isinstance(f, str)
              and f.endswith(".layout.json")), None)
    if f is None:
        return None
    path = _inside(run, bid, f)
    try:
        return f, path, read_bytes(path, "layout", UsageError)
    except UsageError as exc:   # deleted or unreadable since the run: "check the path"
        raise UsageError(f"{str(exc).removesuffix('; check the path')}; the run's manifest "
                         f"lists it: rerun citysynth city into {run}") from None


def _parsed(run: Path, path: Path, data: bytes) -> dict:
    """A layout's bytes parsed, checked for the fields the diff reads."""
    try:
        lay = parse_json(decode(data, path, "layout", UsageError), path, "layout",
                         UsageError)
    except UsageError as exc:   # cut short by a killed run, or edited by hand
        raise UsageError(f"{exc}; the layout is damaged: rerun citysynth city into "
                         f"{run}") from None
    if not isinstance(lay, dict) or not _layout_shape(lay):
        raise UsageError(f"{path}: not a citysynth layout (damaged?); rerun citysynth city "
                         f"into {run}")
    return lay


def _layout_shape(lay: dict) -> bool:
    """The fields the diff reads, of the types it reads them as."""
    try:
        ok = all(isinstance(lay[k], int | float) for k in ("cost", "rank"))
        ok = ok and all(isinstance(i["part"], str) for i in lay["instances"])
        return ok and all(isinstance(t["met"], dict) for s in lay["structures"]
                          for t in s["stages"])
    except (KeyError, TypeError):
        return False


def diff_runs(run_a: str | Path, run_b: str | Path) -> dict[str, Any]:
    """Every difference between two run folders, block by block (see the module)."""
    a, b = Path(run_a), Path(run_b)
    ma, mb = _manifest(a), _manifest(b)
    ba, bb = ma["blocks"], mb["blocks"]
    added, removed = sorted(set(bb) - set(ba)), sorted(set(ba) - set(bb))
    renamed = [_renamed(a, b, ba[old], bb[new], old, new, apart) for old, new, apart
               in same_places(a, b, removed, added)]
    paired = {r["a"] for r in renamed} | {r["b"] for r in renamed}
    added, removed = [i for i in added if i not in paired], [i for i in removed
                                                             if i not in paired]
    status: list[dict[str, Any]] = []
    changed: list[dict[str, Any]] = []
    geometry: list[dict[str, Any]] = []   # the kept layout the same, other files not
    same = 0
    relabelled: list[str] = []   # the same layout, from a library of another hash
    libraries: dict[str, set[str]] = {"a": set(), "b": set()}
    for bid in sorted(set(ba) & set(bb)):
        ra, rb = ba[bid], bb[bid]
        if ra.get("status") != rb.get("status"):
            status.append({"id": bid, "a": ra.get("status"), "b": rb.get("status"),
                           "reason": rb.get("reason") or ra.get("reason")
                           or rb.get("error") or ra.get("error")})
            continue
        la, lb = _layout(a, bid, ra), _layout(b, bid, rb)
        alike = la is not None and lb is not None and la[0] == lb[0] and la[2] == lb[2]
        pa = _parsed(a, la[1], la[2]) if la is not None else None
        pb = pa if alike else _parsed(b, lb[1], lb[2]) if lb is not None else None
        for side, lay in (("a", pa), ("b", pb)):
            if lay is not None:
                libraries[side].add(_library(lay))
        # the layouts were read and compared above: their bytes are not read again
        files = _files_differing(a, b, bid, ra, rb, {la[0]} if alike and la else set())
        if pa is None or pb is None or alike:
            if files:
                geometry.append({"id": bid, "files": files})
            else:
                same += 1
            continue
        if _but_library(pa) == _but_library(pb):   # a comment in manifest.toml, say
            relabelled.append(bid)
            continue
        changed.append({**_block_change(bid, pa, pb), "files": files})
    return {"added": added, "removed": removed, "status": status, "changed": changed,
            "files_changed": geometry, "same": same, "renamed": renamed,
            "library_only": relabelled,
            "identical": not (added or removed or status or changed or geometry or renamed
                              or relabelled),
            "libraries": {k: sorted(v) for k, v in libraries.items()},
            "built_after": {str(run): n for run, m in ((a, ma), (b, mb))
                            if (n := built_after(run, m["blocks"]))}}


def _but_library(lay: dict) -> dict:
    """A layout but the library it names: two runs of libraries that differ only where
    no block looks (a comment in the manifest, a part no block uses) build the same
    layouts under another library hash, which were each listed as changed with nothing
    changed ("cost 12.07 -> 12.07 (+0)") and said to "differ in their parts"."""
    return {k: v for k, v in lay.items() if k != "library"}


def _renamed(a: Path, b: Path, ra: dict, rb: dict, old: str, new: str,
             apart: float) -> dict[str, Any]:
    """A block run B drew in the same place as run A under a new id (``ra``, ``rb``:
    its records): its status, or its kept layout compared (None when cost, rank,
    constraint values and parts agree: the same layout, its parts moved as little as
    the outline)."""
    out: dict[str, Any] = {"a": old, "b": new, "apart_m": apart, "status": None,
                           "change": None}
    if ra.get("status") != rb.get("status"):
        out["status"] = [ra.get("status"), rb.get("status")]
        return out
    la, lb = _layout(a, old, ra), _layout(b, new, rb)
    if la is not None and lb is not None:
        pa, pb = _parsed(a, la[1], la[2]), _parsed(b, lb[1], lb[2])
        change = _block_change(new, pa, pb)
        if _sides_met(pa) == _sides_met(pb):   # its sides numbered from another corner
            change["met"] = []
        if "infill" in change and change["infill"][0] == change["infill"][1]:
            del change["infill"]               # its pockets moved with the outline
        names = [n for n in change.pop("names", []) if str(n[0]).replace(old, new) != n[1]]
        if names:                              # a street block's name holds its id
            change["names"] = names
        moved = {k: v for k, v in change.items() if k not in (
            "id", "cost_a", "cost_b", "rank_a", "rank_b", "cost_delta")}
        if (change["cost_delta"] or change["rank_a"] != change["rank_b"]
                or any(moved.values())):
            out["change"] = {**change, "files": []}   # every file is named anew
    return out


def _files_differing(a: Path, b: Path, bid: str, ra: dict, rb: dict,
                     alike: set[str]) -> list[str]:
    """The block's output files (names within the run) that differ between the runs:
    in one record and not the other, or with other bytes (``alike``: files already
    found the same). Its marker is left out (it holds timings)."""
    fa, fb = ({f for f in r.get("files", []) if isinstance(f, str)} for r in (ra, rb))
    for run, names in ((a, fa), (b, fb)):   # every name checked, listed by one run or both
        for f in sorted(names):
            _inside(run, bid, f)
    return sorted(fa ^ fb | {f for f in sorted(fa & fb - alike)   # sorted: same first error
                             if not _same_bytes(_inside(a, bid, f), _inside(b, bid, f))})


def _same_bytes(pa: Path, pb: Path) -> bool:
    """Whether two files hold the same bytes (two missing files do; one missing does
    not): sizes first, then 1 MB at a time (a block's cut parts can be megabytes)."""
    try:
        sa, sb = _size(pa), _size(pb)
        if sa is None or sb is None or sa != sb:
            return sa is None and sb is None
        with open(pa, "rb") as fa, open(pb, "rb") as fb:
            while True:
                chunk = fa.read(1 << 20)
                if chunk != fb.read(1 << 20):
                    return False
                if not chunk:
                    return True
    except OSError as exc:
        raise UsageError(f"{exc.filename}: cannot read it ({exc.strerror or exc}); check "
                         "that you may read the run folder") from None


def _size(path: Path) -> int | None:
    """The file's size in bytes; None when it is gone."""
    try:
        return path.stat().st_size
    except FileNotFoundError:
        return None


def describe_file(name: str, bid: str) -> str:
    """What a block's output file is, in words: "layout #2's USD layer", "the parts cut
    at its joints"..."""
    base = Path(name).name
    if base == f"{bid}.layout.json":
        return "its kept layout"
    if base == f"{bid}.usda":
        return "its USD (the layouts' variant set)"
    if base.endswith(".cuts.usdc"):
        return "the parts cut or sheared at its joints"
    if m := re.fullmatch(re.escape(bid) + r"_(\d+)\.usda", base):
        return f"layout #{m.group(1)}'s USD layer"
    return base


def _library(lay: dict) -> str:
    """The part library a layout was built with: its name and the start of its hash."""
    lib = lay.get("library") or {}
    return f"{lib.get('name', '?')} ({str(lib.get('hash', ''))[:8]})"


def _block_change(bid: str, la: dict, lb: dict) -> dict:
    change = {"id": bid, "cost_a": la["cost"], "cost_b": lb["cost"],
              "cost_delta": round(lb["cost"] - la["cost"], 6), "rank_a": la["rank"],
              "rank_b": lb["rank"], "met": [], "parts": {}}
    if _library(la) != _library(lb):
        change["library"] = [_library(la), _library(lb)]
    for si, (sa, sb) in enumerate(zip(la["structures"], lb["structures"], strict=False)):
        for s, (ta, tb) in enumerate(zip(sa["stages"], sb["stages"], strict=False)):
            for name in sorted(set(ta["met"]) | set(tb["met"])):
                va, vb = ta["met"].get(name), tb["met"].get(name)
                if va != vb:
                    change["met"].append({"structure": si, "stage": s, "resource": name,
                                          "a": va, "b": vb})
    pa, pb = _part_counts(la), _part_counts(lb)
    change["parts"] = {p: pb.get(p, 0) - pa.get(p, 0) for p in sorted(set(pa) | set(pb))
                       if pa.get(p, 0) != pb.get(p, 0)}
    if len(la["structures"]) != len(lb["structures"]):
        change["structures"] = [len(la["structures"]), len(lb["structures"])]
    names = [[sa.get("name"), sb.get("name")] for sa, sb in
             zip(la["structures"], lb["structures"], strict=False)
             if sa.get("name") != sb.get("name")]
    if names:   # a footprint is named by its place in the file: another order renames
        change["names"] = names
    ia, ib = la.get("infill", []), lb.get("infill", [])
    if ia != ib:
        change["infill"] = [_infill_area(ia), _infill_area(ib)]
    if la.get("version") != lb.get("version"):
        change["version"] = [la.get("version"), lb.get("version")]
    return change


def _sides_met(lay: dict) -> list[list[str]]:
    """Each structure's sides' constraint values, in no order: an outline redrawn can
    start at another corner, which numbers the same sides otherwise."""
    return [sorted(json.dumps(t["met"], sort_keys=True) for t in st["stages"])
            for st in lay["structures"]]


def _infill_area(infill: list[dict]) -> float:
    """The plan area of a layout's roof infill (m²; shells less holes, by the shoelace
    formula: a diff loads no geometry library)."""
    total = 0.0
    for fill in infill:
        for r, ring in enumerate(fill["rings"]):
            area = abs(sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1)
                           in zip(ring, ring[1:] + ring[:1], strict=True))) / 2
            total += area if r == 0 else -area
    return round(total, 1)


def _part_counts(lay: dict) -> dict[str, int]:
    counts: dict[str, int] = {}
    for i in lay["instances"]:
        counts[i["part"]] = counts.get(i["part"], 0) + 1
    return counts


def _check_map_path(png: Path, *runs: str) -> None:
    """``--png`` names a new PNG file or an old one of its own, never a file of the
    runs compared: ``--png runA/manifest.json`` wrote the map over run A's manifest
    (and the next diff called run A "a PNG image, not a run manifest file")."""
    from citysynth.pipeline.city.folder import BLOCKS_DIR, run_file

    if png.is_dir():
        raise UsageError(f"--png {png}: a folder; give the map's file name, e.g. "
                         f"{png / 'diff.png'}")
    for r in runs:
        mine = run_file(r, png)
        if mine == BLOCKS_DIR:
            raise UsageError(f"--png {png}: in run {r}'s {BLOCKS_DIR} folder, which its "
                             "runs rewrite; write the map elsewhere (e.g. diff.png)")
        if mine is not None:
            raise UsageError(f"--png {png}: run {r}'s {mine}, which the map would "
                             "replace; give another file name (e.g. diff.png)")
    if png.suffix.lower() != ".png":
        raise UsageError(f"--png {png}: the map is a PNG image; give a file name ending "
                         f"in .png, e.g. {png.with_suffix('.png')}")


def _warn_unfinished(run_a: str, run_b: str, d: dict[str, Any]) -> None:
    """Warn, on stderr, of a run folder whose blocks are not all of the run its manifest
    tells: a run is writing into it, or a later run stopped before it finished."""
    from citysynth.pipeline.city.process import run_in_progress

    for run in (run_a, run_b):
        if (holder := run_in_progress(Path(run))) is not None:
            print(f"citysynth diff: warning: a citysynth city run ({holder}) is writing "
                  f"into {run}: its blocks are a mix of that run's and the one before; "
                  "diff it again when the run is done", file=sys.stderr)
        elif later := d["built_after"].get(str(Path(run))):
            print(f"citysynth diff: warning: {later} blocks in {run} were built by a later "
                  f"run that stopped before it finished: {MANIFEST} and this comparison "
                  f"are of the run before; run citysynth city into {run} again to finish "
                  "it, then compare", file=sys.stderr)


def run(args) -> int:
    if args.png:
        _check_map_path(Path(args.png), args.run_a, args.run_b)
    d = diff_runs(args.run_a, args.run_b)
    _warn_unfinished(args.run_a, args.run_b, d)
    if args.png:
        from citysynth.pipeline.commands.diff_map import write_map

        write_map(d, Path(args.run_a), Path(args.run_b), Path(args.png))
    if args.json:
        print(json.dumps(d, indent=1, sort_keys=True))
        return 0 if d["identical"] else 1
    print(f"{args.run_a} -> {args.run_b}: {d['same']} blocks the same, "
          f"{len(d['changed'])} changed, " + (
              f"{len(d['files_changed'])} with the same layout but other files, "
              if d["files_changed"] else "") + (
              f"{len(d['library_only'])} the same but for the library they name, "
              if d["library_only"] else "") +
          f"{len(d['added'])} added, {len(d['removed'])} removed, " +
          (f"{len(d['renamed'])} in the same place under a new id, " if d["renamed"]
           else "") + f"{len(d['status'])} changed status")
    if d["libraries"]["a"] != d["libraries"]["b"]:
        print(f"  the runs used different part libraries: {', '.join(d['libraries']['a'])} "
              f"-> {', '.join(d['libraries']['b'])}" + (
                  "; a block the same but for the library it names has the same parts, "
                  "costs and lengths (the libraries differ where no block looks)"
                  if d["library_only"] else ""))
    for c in d["changed"]:
        _print_change(c)
    for g in d["files_changed"]:
        print(f"  files {g['id']}: the kept layout is the same; differ: " + ", ".join(
            describe_file(f, g["id"]) for f in g["files"]))
    for s in d["status"]:
        print(f"  status {s['id']}: {s['a']} -> {s['b']}" +
              (f" ({s['reason']})" if s["reason"] else ""))
    for r in d["renamed"]:
        said = (f"renamed {r['a']} -> {r['b']} (the same block, its outline moved "
                f"{r['apart_m'] * 1000:.1f} mm)")
        if r["change"]:
            _print_change(r["change"], said)
        else:
            print(f"  {said}: " + (f"status {r['status'][0]} -> {r['status'][1]}"
                                   if r["status"] else "the same layout"))
    for bid in d["added"]:
        print(f"  added {bid}")
    for bid in d["removed"]:
        print(f"  removed {bid}")
    if args.png:
        print(f"wrote {args.png}")
    sys.stdout.flush()
    return 0 if d["identical"] else 1


def _print_change(c: dict, said: str = "") -> None:
    """One changed block (``said``: how it is named; by default "changed ID"): its
    cost, ranks, library, what it met, parts, infill, files."""
    print(f"  {said or 'changed ' + c['id']}: cost {c['cost_a']:g} -> {c['cost_b']:g} "
          f"({c['cost_delta']:+g}), layout #{c['rank_a']} -> #{c['rank_b']}" +
          (f", library {c['library'][0]} -> {c['library'][1]}" if "library" in c else ""))
    for m in c["met"][:8]:
        print(f"      ring {m['structure'] + 1}, side {m['stage'] + 1}: {m['resource']} "
              f"{m['a']} -> {m['b']}")
    if c["parts"]:
        moved = ", ".join(f"{p} {n:+d}" for p, n in c["parts"].items())
        print(f"      parts: {moved}")
    if "infill" in c:
        print(f"      roof infill: {c['infill'][0]:g} -> {c['infill'][1]:g} m²")
    if "version" in c:
        print(f"      layout JSON version {c['version'][0]} -> {c['version'][1]}")
    for na, nb in c.get("names", [])[:8]:
        print(f"      named {na} -> {nb} (the input's features in another order, or "
              "renamed)")
    if others := [describe_file(f, c["id"]) for f in c["files"]
                  if not f.endswith(".layout.json")]:
        print(f"      files that differ: {', '.join(others)}")
