"""A command that fails takes back only what it wrote (parts_db/files.py,
``all_or_nothing``): the files it made and replaced, and the folders it made that are
left empty. Two runs writing into one output folder are a pipeline's everyday case (a
farm's jobs sharing ``-o``); a failed or interrupted run removed everything new in the
folder, so one run's Ctrl-C deleted another's finished buildings ("wrote 4 files", then
nothing there), and a failed ``-o a/b/c`` left ``a/b`` behind."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from citysynth.parts_db.files import all_or_nothing, write_text


def _other_run(path: Path, text: str) -> None:
    """Another run's write (its own thread: the block's bookkeeping is per context, as
    it is per process)."""
    t = threading.Thread(target=write_text, args=(path, text))
    t.start()
    t.join()


def test_a_failed_run_keeps_what_another_run_wrote_meanwhile(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.json").write_text("old")
    with pytest.raises(RuntimeError), all_or_nothing(out):
        write_text(out / "a.json", "a")
        write_text(out / "old.json", "replaced")
        _other_run(out / "b.json", "b")
        _other_run(out / "sub" / "b.usda", "b")
        raise RuntimeError("disk full")
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == [
        "b.json", "old.json", "sub", "sub/b.usda"]
    assert (out / "old.json").read_text() == "old"
    assert (out / "b.json").read_text() == "b"


def test_a_failed_run_removes_the_folders_it_made(tmp_path):
    out = tmp_path / "a" / "b" / "c"
    with pytest.raises(KeyboardInterrupt), all_or_nothing(out):
        write_text(out / "parts" / "x.usda", "x")
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_a_folder_another_run_wrote_into_stays(tmp_path):
    out = tmp_path / "a" / "b"
    with pytest.raises(RuntimeError), all_or_nothing(out):
        write_text(out / "x.json", "x")
        _other_run(tmp_path / "a" / "theirs.json", "t")
        raise RuntimeError
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == [
        "a", "a/theirs.json"]


def test_a_run_that_succeeds_keeps_everything_and_no_undo_links(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.json").write_text("old")
    with all_or_nothing(out):
        write_text(out / "old.json", "new")
        write_text(out / "n" / "new.json", "n")
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == [
        "n", "n/new.json", "old.json"]
    assert (out / "old.json").read_text() == "new"
