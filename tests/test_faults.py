"""Faults on a real (small) city run: signals to the main process, damaged run folders,
a full disk, two runs on one folder, a damaged part-database cache, closed pipes.

The city is three blocks between generated streets (lon/lat near Helsinki), so each
run takes seconds; one clean run is the reference every repaired run must equal byte
for byte (layouts, block layers, manifest).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
CLI = [sys.executable, "-m", "citysynth.pipeline.cli"]


def grid_streets(path: Path, blocks: int = 3) -> Path:
    """Streets around ``blocks`` blocks of 70 x 60 m in a row."""
    lon0, lat0 = 24.94, 60.17
    mx, my = 1 / (111320 * math.cos(math.radians(lat0))), 1 / 110540
    lines = [[(i * 70.0, -10.0), (i * 70.0, 70.0)] for i in range(blocks + 1)]
    lines += [[(-10.0, y), (blocks * 70.0 + 10, y)] for y in (0.0, 60.0)]
    feats = [{"type": "Feature", "properties": {"highway": "residential"},
              "geometry": {"type": "LineString",
                           "coordinates": [[lon0 + x * mx, lat0 + y * my] for x, y in ln]}}
             for ln in lines]
    path.write_text(json.dumps({"type": "FeatureCollection", "features": feats}))
    return path


def said(stderr: str) -> str:
    """A command's stderr without the one-time compile notice, which a subprocess prints
    when it is the first to run the solver on this machine (this file run alone)."""
    from citysynth.pipeline.compile_notice import NOTICE

    return stderr.replace(NOTICE + "\n", "", 1)


def city_args(streets: Path, out: Path, *extra: str) -> list[str]:
    return ["city", "--streets", str(streets), "--library", str(LIB), "-o", str(out),
            "--no-overview", *extra]


def snapshot(out: Path) -> dict[str, bytes]:
    """What two runs of the same inputs must write identically."""
    files = sorted((out / "blocks").glob("*.layout.json")) + \
        sorted((out / "blocks").glob("*.usd[ac]")) + [out / "manifest.json"]
    return {p.name: p.read_bytes() for p in files}


@pytest.fixture(scope="module")
def clean_busy(tmp_path_factory):
    """A 48-block city, its clean run: enough work that the workers are still
    building blocks half a second after they start (the parent solves one block
    before they fork, so the three-block city can be done by then, and two workers
    build about 19 blocks a second since 2026-11-26, so twelve were too)."""
    base = tmp_path_factory.mktemp("faults48")
    streets = grid_streets(base / "streets.geojson", blocks=48)
    out = base / "clean"
    assert main(city_args(streets, out, "--workers", "2")) == 0
    return streets, out, snapshot(out)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    base = tmp_path_factory.mktemp("faults")
    streets = grid_streets(base / "streets.geojson")
    out = base / "clean"
    assert main(city_args(streets, out, "--workers", "2")) == 0
    snap = snapshot(out)
    assert len([n for n in snap if n.endswith(".layout.json")]) == 3
    return streets, out, snap


def _state(pid: int) -> str | None:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return None


def alive(pid: int) -> bool:
    return _state(pid) not in (None, "Z", "X")


def children(pid: int) -> set[int]:
    kids: set[int] = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            kids |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            continue
    return kids


def start_and_wait_for_workers(streets: Path, out: Path) -> tuple[subprocess.Popen, set[int]]:
    proc = subprocess.Popen([*CLI, *city_args(streets, out, "--workers", "2")], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 180
    workers: set[int] = set()
    while time.monotonic() < deadline and proc.poll() is None and len(workers) < 2:
        workers = children(proc.pid)
        time.sleep(0.05)
    assert len(workers) == 2, "the run never started its two workers"
    time.sleep(0.5)          # both are building a block now
    return proc, workers


@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130),
                                       (signal.SIGKILL, -9)])
def test_a_signal_stops_the_workers_and_the_rerun_repairs(clean_busy, tmp_path, sig,
                                                          code):
    streets, _, snap = clean_busy
    out = tmp_path / "run"
    proc, workers = start_and_wait_for_workers(streets, out)
    os.kill(proc.pid, sig)
    t0 = time.monotonic()
    _, err = proc.communicate(timeout=30)
    if sig != signal.SIGKILL:
        assert time.monotonic() - t0 < 1.5, "the run took too long to stop"
        assert "Traceback" not in err, err
    assert proc.returncode == code, err
    time.sleep(1.0)
    assert not [w for w in workers if alive(w)], "a worker outlived its run"
    assert main(city_args(streets, out, "--workers", "2")) == 0
    assert snapshot(out) == snap
    assert not [p for p in out.rglob(".*") if p.is_file()], "temporaries left behind"


def test_damaged_blocks_and_markers_are_rebuilt(clean, tmp_path, capsys):
    streets, ref, snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    blocks = sorted((out / "blocks").glob("*.layout.json"))
    markers = sorted((out / "blocks").glob("*.done.json"))
    text = blocks[0].read_text()
    blocks[0].write_text(text[: len(text) // 2])            # truncated, marker intact
    markers[1].write_text("[1, 2, 3]")                      # valid JSON, wrong shape
    bad = json.loads(markers[2].read_text())
    bad["hashes"] = "none"                                  # a wrong-shaped field
    markers[2].write_text(json.dumps(bad))
    capsys.readouterr()
    assert main(city_args(streets, out, "--workers", "1")) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["cached"] == 0 and report["counts"]["built"] == 3
    assert snapshot(out) == snap
    for marker in [{"status": "built"}, None, "text", {"id": 3}]:   # and each alone
        markers[0].write_text(json.dumps(marker))
        assert main(city_args(streets, out, "--workers", "1")) == 0
        assert json.loads((out / "report.json").read_text())["counts"]["cached"] == 2
    assert snapshot(out) == snap


def test_a_half_written_block_no_longer_asked_for_is_removed(clean, tmp_path):
    """A block a killed run left half-written (its layout JSON and USD, no marker)
    stayed in the folder for good once the streets no longer made it: the folder
    held a block no manifest lists. It goes, as a stale block with a marker does."""
    streets, ref, snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    blocks = out / "blocks"
    first = sorted(blocks.glob("*.done.json"))[0].name[: -len(".done.json")]
    orphan = "b0000000000"
    for p in sorted(blocks.glob(f"{first}*")):
        if not p.name.endswith(".done.json"):
            shutil.copy(p, blocks / p.name.replace(first, orphan, 1))
    assert len(list(blocks.glob(f"{orphan}*"))) >= 3
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert not list(blocks.glob(f"{orphan}*"))
    assert snapshot(out) == snap


@pytest.mark.parametrize("where, how", [("blocks/parts", "file"),
                                        ("blocks/parts/materials", "file"),
                                        ("blocks", "loop"), ("blocks/parts", "loop")])
def test_a_run_folders_subfolder_that_is_no_folder_is_refused_first(clean, tmp_path, capsys,
                                                                    where, how):
    """``blocks/parts`` replaced by a file (or a link loop at ``blocks``): every block
    was solved, then every one failed ("could not write ...: File exists"), and the
    manifest was written again with no blocks. Refused before any block, as a file
    named ``blocks`` was; the run folder is left as it was."""
    streets, ref, _snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    target = out / where
    shutil.rmtree(target)
    if how == "file":
        target.write_text("not a folder\n")
    else:
        target.symlink_to(target)
    before = (out / "manifest.json").read_bytes()
    capsys.readouterr()
    assert main(city_args(streets, out, "--workers", "1")) == 2
    err = said(capsys.readouterr().err)
    assert str(target) in err and ("a file where the run keeps" in err if how == "file"
                                   else "a link that leads to no folder" in err), err
    assert (out / "manifest.json").read_bytes() == before


@pytest.mark.parametrize("edit", [{"status": "failed", "reason": "hand edit"},
                                  {"cost": 0.5}, {"rank": 2}])
def test_a_marker_edited_by_hand_means_rebuild(clean, tmp_path, edit):
    """A marker whose files' hashes were right was trusted whatever else it said: a
    status edited to "failed" dropped the block from the city (exit 1), a cost or rank
    edited went into the manifest, and ``diff`` called the runs the same. A marker is
    sealed with the hash of its own content: edited, the block is built again."""
    streets, ref, snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    marker = sorted((out / "blocks").glob("*.done.json"))[0]
    marker.write_text(json.dumps({**json.loads(marker.read_text()), **edit}))
    assert main(city_args(streets, out, "--workers", "1")) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["built"] == 3 and report["counts"]["cached"] == 2
    assert snapshot(out) == snap


def test_progress_and_summary_agree(clean, tmp_path, capsys):
    streets, ref, _ = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    next(iter(sorted((out / "blocks").glob("*.done.json")))).unlink()
    assert main(city_args(streets, out, "--workers", "1")) == 0
    cap = capsys.readouterr()
    last = [ln for ln in cap.err.splitlines() if ln.startswith("[")][-1]
    table = dict(ln.rsplit(None, 1) for ln in cap.out.splitlines()
                 if ln.split()[:1] in (["built"], ["failed"], ["skipped"], ["cached"]))
    assert (f"built {table['built']}, failed {table['failed']}, skipped "
            f"{table['skipped']}, cached {table['cached']}") in last
    assert last.startswith("[3/3]")


def test_a_second_run_on_the_folder_is_refused(clean, tmp_path, capsys):
    from citysynth.pipeline.city.process import LOCK, run_lock

    streets, ref, snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    with run_lock(out):
        assert main(city_args(streets, out, "--workers", "1")) == 2
        cap = capsys.readouterr()
        err = cap.err
        assert "another citysynth city run" in err and f"pid {os.getpid()}" in err
        assert len(err.strip().splitlines()) == 1
        assert cap.out == "", cap.out   # refused before "N blocks to build" (until 11-30)
    (out / LOCK).write_text("999999999 2026-01-01T00:00:00\n")   # a crashed run's lock
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert not (out / LOCK).exists() and snapshot(out) == snap


@pytest.mark.parametrize("what", ["link", "folder"])
def test_a_link_or_folder_at_the_lock_is_refused_and_nothing_outside_is_written(
        clean, tmp_path, capsys, what):
    """A link at the run's lock file had the run open its target, truncate it and
    write its pid there (a file outside the run folder lost its content, exit 0); a
    folder there gave "Is a directory; ... choose another name". Both are refused,
    naming what to remove, and the target is untouched."""
    from citysynth.pipeline.city.process import LOCK

    streets, ref, snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    victim = tmp_path / "victim.txt"
    victim.write_text("important user data\n")
    if what == "link":
        (out / LOCK).symlink_to(victim)
    else:
        (out / LOCK).mkdir()
    assert main(city_args(streets, out, "--workers", "1")) == 2
    err = said(capsys.readouterr().err)
    assert f"a {what} where the run keeps its lock file; remove the {what}" in err, err
    assert victim.read_text() == "important user data\n"


def test_diff_of_a_folder_a_run_is_writing_warns(clean, tmp_path, capsys):
    """``citysynth diff`` of a folder a city run was writing into counted a mix of old
    and new blocks without a word; it warns, naming the run, and still compares."""
    from citysynth.pipeline.city.process import run_lock

    streets, ref, _snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    capsys.readouterr()
    with run_lock(out):
        assert main(["diff", str(ref), str(out)]) == 0
    err = capsys.readouterr().err
    assert f"a citysynth city run (pid {os.getpid()}) is writing into {out}" in err, err
    assert main(["diff", str(ref), str(out)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_diff_of_a_folder_a_first_run_left_unfinished_says_to_finish_it(clean, tmp_path,
                                                                      capsys):
    """A first run killed before its manifest left blocks but no manifest.json: diff
    called it "not a citysynth run folder", with no word of the run to finish."""
    streets, ref, _snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    (out / "manifest.json").unlink()
    assert main(["diff", str(ref), str(out)]) == 2
    err = said(capsys.readouterr().err)
    assert f"{out}: a citysynth city run stopped here before it finished (3 blocks " \
        "built, no manifest.json yet); run the same citysynth city into" in err, err
    shutil.rmtree(out / "blocks")   # nothing of a run at all: as before
    assert main(["diff", str(ref), str(out)]) == 2
    assert "not a citysynth run folder (no manifest.json)" in capsys.readouterr().err


def test_diff_warns_of_blocks_a_later_unfinished_run_built(clean, tmp_path, capsys):
    """A second run stopped before its end leaves the first run's manifest beside blocks
    of its own: diff compared the manifest's run without a word. It warns, counting the
    blocks built since (a block of new inputs, a block the manifest lacks)."""
    streets, ref, _snap = clean
    out = tmp_path / "run"
    shutil.copytree(ref, out)
    markers = sorted((out / "blocks").glob("*.done.json"))
    marker = json.loads(markers[0].read_text())
    markers[0].write_text(json.dumps({**marker, "input_hash": "0" * 64}))
    shutil.copy(markers[1], out / "blocks" / "bnewblock00.done.json")
    capsys.readouterr()
    assert main(["diff", str(ref), str(out)]) == 0
    err = said(capsys.readouterr().err)
    assert f"warning: 2 blocks in {out} were built by a later run that stopped before " \
        "it finished" in err, err
    assert main(["diff", "--json", str(ref), str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["built_after"] == {str(out): 2}
    assert main(["diff", str(ref), str(ref)]) == 0
    assert "warning" not in capsys.readouterr().err


def test_a_second_process_is_refused_while_a_run_holds_the_folder(clean, tmp_path):
    streets, ref, _ = clean
    out = tmp_path / "run"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import sys, time; from pathlib import Path\n"
        "from citysynth.pipeline.city.process import run_lock\n"
        f"with run_lock(Path({str(out)!r})):\n"
        "    print('held', flush=True); time.sleep(120)")],
        cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        second = subprocess.run([*CLI, *city_args(streets, out, "--workers", "1")],
                                cwd=ROOT, capture_output=True, text=True, timeout=120)
    finally:
        holder.kill()
        holder.wait()
    assert second.returncode == 2, second.stderr
    assert f"another citysynth city run (pid {holder.pid})" in second.stderr
    assert "Traceback" not in second.stderr and len(said(second.stderr).splitlines()) == 1


def _mount_tmpfs(where: Path, size: str) -> None:
    where.mkdir()
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)],
                         capture_output=True, text=True)
    if res.returncode != 0:
        reason = f"cannot mount a small filesystem here ({res.stderr.strip()})"
        print(reason)
        pytest.skip(reason)


def test_a_full_disk_at_the_manifest_still_shows_what_the_blocks_came_to(
        clean, tmp_path, capsys, monkeypatch):
    """A disk that filled at ``manifest.json`` (after the blocks) printed only the one
    line, "manifest.json: No space left on device": no table of what was built or
    failed, as a full disk at ``city.usda`` prints. The table comes first now."""
    import errno

    from citysynth.pipeline.city import outputs

    streets, _, _snap = clean
    real = outputs.write_text

    def full(path, text):
        if Path(path).name == "manifest.json":
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real(path, text)
    monkeypatch.setattr(outputs, "write_text", full)
    capsys.readouterr()
    assert main(city_args(streets, tmp_path / "run", "--workers", "1")) == 2
    cap = capsys.readouterr()
    table = [ln.split() for ln in cap.out.splitlines()]
    assert ["built", "3"] in table and ["failed", "0"] in table, cap.out
    assert "manifest.json: No space left on device" in said(cap.err)


def test_a_failed_street_block_is_not_called_feature_0(clean, tmp_path, monkeypatch):
    """A street block's skeleton is named "feature 0 (<id>)": its failure was reported
    as "failed b95829418cb: feature 0 (b95829418cb): the convex corner of ...". The
    reason beside its id now starts with what failed."""
    from citysynth.pipeline.city import jobs
    from citysynth.skeletons import SkeletonError

    streets, _, snap = clean
    victim = sorted(n[:-len(".layout.json")] for n in snap if n.endswith(".layout.json"))[0]
    solve = jobs.solve_block

    def sharp(job, db):
        if job.id == victim:
            raise SkeletonError(f"feature 0 ({job.id}): the convex corner of 14.5° at "
                                "(7.1, 50.7) is too sharp for its sides")
        return solve(job, db)

    monkeypatch.setattr(jobs, "solve_block", sharp)
    assert main(city_args(streets, tmp_path / "run", "--workers", "1")) == 1
    report = json.loads((tmp_path / "run" / "report.json").read_text())
    (failed,) = report["failed"]
    assert failed["id"] == victim and failed["reason"].startswith("the convex corner of "), \
        failed


def test_a_block_the_machine_cannot_write_exits_2_and_the_rerun_recovers(clean, tmp_path,
                                                                        capsys, monkeypatch):
    """A block whose files the machine refuses (no permission, here) fails unrecorded,
    the others are built, and the city exits 2, the machine's refusal, with a line
    saying how many and why (it exited 1, which a pipeline reads as "infeasible"); the
    rerun builds it."""
    import errno

    from citysynth.pipeline.city import jobs

    streets, _, snap = clean
    out = tmp_path / "run"
    write = jobs.write_block
    victim = sorted(n[:-len(".layout.json")] for n in snap if n.endswith(".layout.json"))[0]

    def refused(built, rank, db, blocks):
        if built.name == victim:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES),
                                  str(blocks / f"{victim}.layout.json"))
        return write(built, rank, db, blocks)

    monkeypatch.setattr(jobs, "write_block", refused)
    assert main(city_args(streets, out, "--workers", "1")) == 2
    err = capsys.readouterr().err
    assert f"1 block(s) could not be written, e.g. {victim}: could not write " \
        f"{out / 'blocks' / victim}.layout.json: Permission denied; fix the permissions " \
        "and run again (a failure of the machine, not recorded: the next run builds the " \
        "block)" in err, err
    assert "Traceback" not in err
    report = json.loads((out / "report.json").read_text())
    assert report["machine_failed"] == [victim] and report["counts"]["built"] == 2
    assert not (out / "blocks" / f"{victim}.done.json").exists()
    monkeypatch.setattr(jobs, "write_block", write)
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert snapshot(out) == snap


def test_a_full_disk_is_never_cached_and_the_rerun_recovers(clean, tmp_path, capsys):
    streets, _, snap = clean
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "200k")
    try:
        out = disk / "run"
        code = main(city_args(streets, out, "--workers", "1"))
        cap = capsys.readouterr()
        assert code == 2, cap          # the machine's refusal (it was 1, "infeasible")
        assert "Traceback" not in cap.err
        assert "No space left on device" in cap.out + cap.err
        for marker in (out / "blocks").glob("*.done.json"):   # any marker is a success
            assert json.loads(marker.read_text())["status"] == "built"
        subprocess.run(["mount", "-o", "remount,size=8m", str(disk)], check=True)
        assert main(city_args(streets, out, "--workers", "1")) == 0
        assert snapshot(out) == snap
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def test_a_full_disk_at_the_city_glb_still_prints_the_summary(clean, tmp_path, capsys,
                                                               monkeypatch):
    """``--glb`` on a disk that fills up at the city's GLB: the blocks are built and
    cached, but the run ended on the GLB's one line with no word of them (the summary
    table was printed after the city's files). It is printed first, then the line."""
    import errno

    from citysynth.pipeline.city import outputs

    streets, _, _snap = clean

    def full(out, inputs, report):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(out / "city.glb"))

    monkeypatch.setattr(outputs, "write_city_glb", full)
    out = tmp_path / "run"
    assert main(city_args(streets, out, "--workers", "1", "--glb")) == 2
    cap = capsys.readouterr()
    assert "built / attempted" in cap.out and "100.0%" in cap.out, cap.out
    last = cap.err.strip().splitlines()[-1]    # after the progress lines
    assert last.endswith(f"{out / 'city.glb'}: No space left on device; free space and "
                         "run again"), cap.err
    assert "Traceback" not in cap.err


def test_a_rerun_sweeps_the_temporaries_a_killed_run_left_in_the_materials(tmp_path):
    """A run killed while it wrote a library material left its zero-byte temporary in
    ``blocks/parts/materials``, which no later run swept."""
    streets, out = grid_streets(tmp_path / "s.geojson", 1), tmp_path / "run"
    assert main(city_args(streets, out, "--workers", "1")) == 0
    left = out / "blocks" / "parts" / "materials" / ".trim_f6f2e8.tmp-tvp_2ehb.usda"
    left.write_bytes(b"")
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert not left.exists()


def test_a_full_disk_in_block_names_the_file_and_leaves_only_whole_files(tmp_path, capsys):
    """``block`` on a disk that fills up while it writes: exit 2, one line naming the file
    it could not write (Python's full-disk error on flush names none), and every file
    left is whole: no temporary, each layout JSON parses."""
    from citysynth.skeletons.geojson import lonlat_from_local
    ring = lonlat_from_local([(0, 0), (30, 0), (30, 20), (0, 20), (0, 0)], (24.94, 60.17))
    f = tmp_path / "x.geojson"
    f.write_text(json.dumps({"type": "Feature", "properties": {"id": "x"},
                             "geometry": {"type": "Polygon", "coordinates": [ring]}}))
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "60k")
    try:
        code = main(["block", str(f), "--library", str(LIB), "-o", str(disk / "b"),
                     "--k", "3"])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
        assert err.startswith(f"citysynth block: error: {disk / 'b'}/") and \
            ": No space left on device; free space" in err, err
        left = [p for p in disk.rglob("*") if p.is_file()]
        assert not [p for p in left if ".tmp-" in p.name]
        for p in left:
            if p.name.endswith(".json"):
                json.loads(p.read_text())
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def test_a_write_the_disk_refuses_names_its_file(tmp_path, monkeypatch):
    """Python's full-disk error on flush names no file: the atomic writer names the one
    it was writing (not its temporary), and leaves no temporary behind."""
    import errno

    from citysynth.parts_db import files

    def full(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(Path, "write_bytes", full)
    target = tmp_path / "out" / "x.layout.json"
    with pytest.raises(OSError) as exc:
        files.write_bytes(target, b"{}")
    assert (exc.value.errno, exc.value.filename) == (errno.ENOSPC, str(target))
    assert list((tmp_path / "out").iterdir()) == []


def test_a_damaged_part_database_cache_heals(tmp_path, monkeypatch):
    from citysynth.parts_db import load_library
    from citysynth.parts_db.library import DB_JSON, DB_NPZ, cache_dir

    monkeypatch.setenv("CITYSYNTH_CACHE", str(tmp_path / "cache"))
    first = load_library(LIB)
    folder = cache_dir(LIB)
    damage = [(DB_NPZ, lambda b: b[: len(b) // 2]), (DB_NPZ, lambda b: b[:-9] + b"123456789"),
              (DB_JSON, lambda b: b.replace(b'"parts"', b'"partz"'))]
    for name, how in damage:
        f = folder / name
        f.write_bytes(how(f.read_bytes()))
        db = load_library(LIB)
        assert not db.cache_hit and db.ids == first.ids, name
        assert load_library(LIB).cache_hit, f"{name}: the cache did not heal"


def test_a_closed_pipe_ends_quietly(clean):
    """The reader is gone before the first write (as ``| head -1`` is after a line)."""
    _, ref, _ = clean
    for args in (["diff", str(ref), str(ref), "--json"], ["--help"],
                 ["solve", str(ROOT / "examples" / "street_front.json"), "--json"]):
        r, w = os.pipe()
        os.close(r)
        try:
            res = subprocess.run([*CLI, *args], stdout=w, stderr=subprocess.PIPE, cwd=ROOT,
                                 text=True, timeout=300)
        finally:
            os.close(w)
        assert said(res.stderr) == "", (args, res.stderr)
        assert res.returncode == (0 if args == ["--help"] else 141), args


def _mount_readonly(where: Path) -> None:
    _mount_tmpfs(where, "1m")
    subprocess.run(["mount", "-o", "remount,ro", str(where)], check=True)


@pytest.mark.parametrize("cmd", ["building", "city", "ingest", "demo"])
def test_a_read_only_output_folder_is_one_message(tmp_path, capsys, cmd):
    ro = tmp_path / "ro"
    _mount_readonly(ro)
    try:
        out = str(ro / "out")
        lines = ROOT / "examples" / "skeletons" / "t_building.geojson"
        argv = {"building": ["building", str(lines), "--library", str(LIB), "-o", out],
                "city": city_args(grid_streets(tmp_path / "s.geojson", 1), Path(out)),
                "ingest": ["ingest", str(LIB), "-o", out], "demo": ["demo", "-o", out]}[cmd]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "may not be written" in err and str(ro) in err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
        assert not list(ro.iterdir())
    finally:
        subprocess.run(["umount", "-l", str(ro)], check=False)


def test_an_output_folder_in_proc_is_refused_before_the_solve(capsys):
    """Root may write anywhere by the permission bits, /proc too, where no folder can
    be made: the refusal comes before the solve, not from the first file written."""
    lines = ROOT / "examples" / "skeletons" / "t_building.geojson"
    assert main(["building", str(lines), "--library", str(LIB), "-o",
                 "/proc/citysynth-out"]) == 2
    err = capsys.readouterr().err
    assert "/proc: may not be written" in err and "citysynth-out cannot be made" in err
    assert len(err.strip().splitlines()) == 1
    assert not any(p.name.startswith(".citysynth-probe") for p in Path("/proc").iterdir())


def test_a_latin1_locale_refuses_names_usd_core_would_misspell(tmp_path, capsys,
                                                                 monkeypatch):
    """usd-core names files in UTF-8 whatever the locale: under a Latin-1 locale the
    USD of ``-o out_ä`` went to ``out_Ã¤`` and ``out_ä`` kept empty files (exit 0)."""
    import citysynth.pipeline.paths as paths
    monkeypatch.setattr(paths.sys, "getfilesystemencoding", lambda: "iso8859-1")
    out = tmp_path / "out_ä"
    assert main(["tower", "--height", "60", "--far", "5", "--lot-area", "900",
                 "--no-preview", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "-o: " in err and "this locale encodes file names in iso8859-1" in err
    assert "LC_ALL=C.UTF-8" in err and not out.exists()
    assert main(["tower", "--height", "60", "--far", "5", "--lot-area", "900",
                 "--no-preview", "-o", str(tmp_path / "out")]) == 0   # ASCII names are fine


def test_bytes_that_are_no_utf8_in_a_name_are_one_message(tmp_path):
    out = os.fsencode(tmp_path) + b"/out_\xe4"
    res = subprocess.run([*CLI, "tower", "--height", "60", "--far", "5", "--lot-area",
                          "900", "--no-preview", "-o", out], capture_output=True, text=True,
                         cwd=ROOT, timeout=300)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert "is not UTF-8 text" in res.stderr and not os.path.exists(out)


def test_a_latin1_terminal_gets_the_summary_not_a_crash(tmp_path):
    """"≤" in a summary line crashed a command on a Latin-1 terminal after writing its
    files (exit 3, "a bug")."""
    env = {**os.environ, "PYTHONIOENCODING": "iso8859-1"}
    res = subprocess.run([*CLI, "tower", "--height", "60", "--far", "5", "--lot-area",
                          "900", "--no-preview", "-o", str(tmp_path)], capture_output=True,
                         cwd=ROOT, timeout=300, env=env)
    assert res.returncode == 0, res.stderr
    assert b"stretch ? 0.00 %" in res.stdout and b"floor area" in res.stdout


def test_a_read_only_cache_folder_falls_back(tmp_path, monkeypatch, capsys):
    """$CITYSYNTH_CACHE on a read-only file system: the database is cached in the user
    cache folder instead, and the command works."""
    from citysynth.parts_db import load_library
    ro = tmp_path / "ro"
    _mount_readonly(ro)
    try:
        monkeypatch.setenv("CITYSYNTH_CACHE", str(ro))
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "user-cache"))
        db = load_library(LIB)
        assert db.path is not None and str(db.path).startswith(str(tmp_path / "user-cache"))
        assert not list(ro.iterdir())
    finally:
        subprocess.run(["umount", "-l", str(ro)], check=False)


def test_a_city_with_failed_blocks_exits_1_and_is_complete(clean, tmp_path, capsys):
    streets, _, _ = clean
    cfg = tmp_path / "city.toml"
    cfg.write_text("k = 1\n[per_side]\ndoors = [40, 50]\n")     # no side has room
    out = tmp_path / "run"
    assert main(city_args(streets, out, "--workers", "1", "--config", str(cfg))) == 1
    report = json.loads((out / "report.json").read_text())
    assert report["counts"]["failed"] == 3 and (out / "manifest.json").is_file()
    assert "failed b" in capsys.readouterr().out
    assert main(city_args(streets, out, "--workers", "1", "--config", str(cfg))) == 1
    assert json.loads((out / "report.json").read_text())["counts"]["cached"] == 3


def test_a_cold_kernel_cache_is_announced(tmp_path, monkeypatch, capsys):
    from citysynth.pipeline import cli, compile_notice

    code = ("from citysynth.pipeline.compile_notice import kernels_cold; "
            "print(kernels_cold())")
    cold = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty")})
    assert cold.stdout.strip() == "True", cold.stderr
    monkeypatch.setattr(compile_notice, "kernels_cold", lambda: True)
    monkeypatch.setattr(compile_notice, "_SAID", [])     # (said once in a process)
    assert cli.main(["solve", str(ROOT / "examples" / "facade_small.json")]) == 0
    assert compile_notice.NOTICE in capsys.readouterr().err


def test_a_city_announces_compiling_once_its_inputs_are_read(tmp_path, monkeypatch,
                                                            capsys):
    """A city.toml refused in a second was told after "compiling the solver kernels
    once, about 60 s" (two lines, the first untrue); a city says it only when it has
    blocks to solve, and a run whose blocks are all done says nothing."""
    from citysynth.pipeline import compile_notice

    monkeypatch.setattr(compile_notice, "kernels_cold", lambda: True)
    monkeypatch.setattr(compile_notice, "_SAID", [])     # (said once in a process)
    streets, out = grid_streets(tmp_path / "s.geojson", 1), tmp_path / "run"
    bad = tmp_path / "c.toml"
    bad.write_text("k = 0\n")
    assert main(city_args(streets, out, "--workers", "1", "--config", str(bad))) == 2
    assert compile_notice.NOTICE not in capsys.readouterr().err
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert capsys.readouterr().err.count(compile_notice.NOTICE) == 1
    compile_notice._SAID.clear()      # a new process, its blocks all done
    assert main(city_args(streets, out, "--workers", "1")) == 0
    assert compile_notice.NOTICE not in capsys.readouterr().err


def test_sigterm_after_the_blocks_still_exits_143(clean, tmp_path, monkeypatch, capsys):
    """SIGTERM while the city stage is written (every block built, the workers gone)
    stops the command as Ctrl-C does, exit 143, not a kill by the signal's default
    action (it was, once two workers built a small city in under half a second)."""
    import citysynth.pipeline.city.outputs as outputs  # the command imports it when run

    def finish(*args, **kwargs):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)            # the handler raises before this ends
        raise AssertionError("SIGTERM was not handled")

    monkeypatch.setattr(outputs, "finish_city", finish)
    streets, _ref, _snap = clean
    assert main(city_args(streets, tmp_path / "run", "--workers", "1")) == 143
    assert "terminated" in capsys.readouterr().err
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_failed_rewrite_leaves_the_earlier_result_whole(tmp_path, monkeypatch, capsys):
    """``street`` run again into its folder, the disk filling at the GLB: the new
    layout JSON and USD stood beside the old GLB (a mixed result, exit 2). The files
    it replaced get their old content back, and its new ones go."""
    import errno

    from citysynth.export import writers
    line = tmp_path / "main.geojson"
    line.write_text(json.dumps({
        "type": "FeatureCollection",
        "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::25832"}},
        "features": [{"type": "Feature", "properties": {}, "geometry": {
            "type": "LineString", "coordinates": [[690000.0, 5335000.0],
                                                  [690120.0, 5335000.0]]}}]}))
    out = tmp_path / "out"
    assert main(["street", "--line", str(line), "--side", "right", "--no-preview",
                 "-o", str(out)]) == 0
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def full(lay, db, path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
    monkeypatch.setitem(writers.WRITERS, "glb", full)
    capsys.readouterr()
    assert main(["street", "--line", str(line), "--side", "both", "--no-preview",
                 "-o", str(out)]) == 2
    assert "No space left on device" in capsys.readouterr().err
    after = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after.keys() == before.keys()
    assert [k for k in before if after[k] != before[k]] == []


@pytest.mark.parametrize("found", ["report.json", "city.png", "manifest.json"])
def test_a_folder_that_is_no_run_keeps_its_files(clean, tmp_path, capsys, found):
    """``-o`` on a folder that is not a city run (a project folder with a report.json of
    its own, a web app's manifest.json): the run wrote its own over the file without a
    word. Refused before anything is written; the folder is left as it was."""
    streets, _ref, _snap = clean
    out = tmp_path / "project"
    out.mkdir()
    (out / found).write_text('{"mine": true}\n')
    capsys.readouterr()
    assert main(city_args(streets, out, "--workers", "1")) == 2
    err = said(capsys.readouterr().err)
    assert ("not the manifest of a citysynth city run" in err if found == "manifest.json"
            else f"not the folder of a citysynth city run (it has no manifest.json), and "
                 f"the run would write over its {found}" in err), err
    assert "give a new or empty -o folder" in err, err
    assert sorted(p.name for p in out.iterdir()) == [found]
    assert (out / found).read_text() == '{"mine": true}\n'


def test_a_run_folder_and_a_first_run_killed_early_are_still_run_into(clean, tmp_path):
    """The guard above passes a run's own folder (it has its manifest) and one a first
    run left before its manifest (blocks only)."""
    streets, ref, _snap = clean
    again = tmp_path / "again"
    shutil.copytree(ref, again)
    assert main(city_args(streets, again, "--workers", "1")) == 0
    early = tmp_path / "early"
    shutil.copytree(ref / "blocks", early / "blocks")
    assert main(city_args(streets, early, "--workers", "1")) == 0
    assert (early / "manifest.json").is_file()
