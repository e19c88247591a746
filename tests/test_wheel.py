"""The wheel as a pip user gets it: built from the repository's files, installed into a
fresh venv beside another distribution ("studio-tools") that ships its own top-level
``pipeline`` and ``export`` packages, as studio pipelines often do. Both import, the
wheel holds nothing but ``citysynth``, ``citysynth --version`` and ``citysynth demo``
work from an empty folder (caches in the user's cache folder, nothing written beside
site-packages), and uninstalling either distribution leaves the other whole.

The fresh venv gets citysynth's dependencies without downloading: a .pth file points
at the test environment's site-packages folders (.pth files inside them are not run,
so its editable citysynth stays invisible). The demo compiles the numba kernels
afresh in the new install, about a minute: the one slow step of this module.
"""

from __future__ import annotations

import base64
import csv
import hashlib
import importlib.metadata
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
STUDIO = {  # studio-tools: top-level packages named like citysynth's subpackages
    "pipeline/__init__.py": "NAME = 'studio pipeline'\n",
    "export/__init__.py": "NAME = 'studio export'\n",
    "export/fbx.py": "def write(path):\n    return f'fbx to {path}'\n",
}
JUNK = (".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", ".*_cache", ".hypothesis",
        ".citysynth", "out")
TIMEOUT = 1800  # s; the demo's numba compile on a busy machine stays well inside


def _run(cmd: list, **kw) -> subprocess.CompletedProcess:
    """Run a command, failing with its output when it fails."""
    p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True,
                       timeout=TIMEOUT, **kw)
    assert p.returncode == 0, f"{cmd} exited {p.returncode}\n{p.stdout[-3000:]}\n{p.stderr[-3000:]}"
    return p


def _record_line(path: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{path},sha256={digest},{len(data)}"


def _studio_wheel(out: Path) -> Path:
    """A minimal, valid wheel of studio-tools 1.0 (no build tool needed)."""
    info = "studio_tools-1.0.dist-info"
    files = {**STUDIO,
             f"{info}/METADATA": "Metadata-Version: 2.1\nName: studio-tools\nVersion: 1.0\n",
             f"{info}/WHEEL": "Wheel-Version: 1.0\nGenerator: citysynth-tests\n"
                              "Root-Is-Purelib: true\nTag: py3-none-any\n"}
    record = [_record_line(p, t.encode()) for p, t in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = "\n".join(record) + "\n"
    path = out / "studio_tools-1.0-py3-none-any.whl"
    with zipfile.ZipFile(path, "w") as z:
        for name, text in files.items():
            z.writestr(name, text)
    return path


def _source_copy(dest: Path) -> Path:
    """The repository's files as a clean clone of the working tree would hold them
    (tracked and new files, not ignored ones), so the build writes nothing into the
    source tree."""
    try:
        git = subprocess.run(["git", "ls-files", "-z", "--cached", "--others",
                              "--exclude-standard"], cwd=ROOT, capture_output=True, check=True)
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: skip the usual junk
        shutil.copytree(ROOT, dest, ignore=shutil.ignore_patterns(*JUNK))
        return dest
    for rel in filter(None, git.stdout.decode().split("\0")):
        src = ROOT / rel
        if src.is_file():  # (a tracked file deleted in the working tree is not)
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            (dest / rel).write_bytes(src.read_bytes())
    return dest


def _offline_build() -> bool:
    """Whether this environment holds the build requirements (setuptools>=68, wheel),
    so pip can build without fetching them into an isolated environment."""
    try:
        major = int(importlib.metadata.version("setuptools").split(".")[0])
        importlib.metadata.version("wheel")
    except importlib.metadata.PackageNotFoundError:
        return False
    return major >= 68


def _site(venv: Path) -> Path:
    return Path(subprocess.run([venv / "bin" / "python", "-c",
                                "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())


def _env(home: Path) -> dict[str, str]:
    """A user's environment: own home and cache folder, no test-session cache."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("CITYSYNTH_CACHE", "PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    return {**env, "HOME": str(home), "XDG_CACHE_HOME": str(home / ".cache"),
            "PYTHONNOUSERSITE": "1"}


def _pip(venv: Path, *args) -> subprocess.CompletedProcess:
    """This environment's pip acting on the fresh venv (which has no pip of its own)."""
    return _run([sys.executable, "-m", "pip", "--python", venv / "bin" / "python",
                 "--disable-pip-version-check", *args])


def _install(venv: Path, *wheels: Path) -> None:
    _pip(venv, "install", "--no-deps", "--no-index", "--force-reinstall", *wheels)


def _intact(site: Path, dist_info: str) -> list[str]:
    """The files of an installed distribution missing or changed since pip wrote them
    (checked against the hashes in its RECORD)."""
    bad = []
    with open(site / dist_info / "RECORD", newline="", encoding="utf-8") as f:
        for path, digest, _size in csv.reader(f):
            if not digest:
                continue
            file = site / path
            algo, _, want = digest.partition("=")
            if not file.is_file():
                bad.append(f"{path}: missing")
                continue
            got = base64.urlsafe_b64encode(hashlib.new(algo, file.read_bytes()).digest())
            if got.rstrip(b"=").decode() != want:
                bad.append(f"{path}: changed")
    return bad


@pytest.fixture(scope="module")
def wheels(tmp_path_factory) -> tuple[Path, Path]:
    """citysynth's wheel built from a copy of the repository, and studio-tools'."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = _source_copy(tmp / "src")
    out = tmp / "dist"
    # without the build requirements here, pip fetches them (from its cache or index)
    isolation = ["--no-build-isolation"] if _offline_build() else []
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", *isolation, "-w", out, src])
    (built,) = out.glob("citysynth-*.whl")
    return built, _studio_wheel(out)


@pytest.fixture(scope="module")
def venv(wheels, tmp_path_factory) -> Path:
    """A fresh venv with both wheels installed, citysynth's dependencies borrowed."""
    v = tmp_path_factory.mktemp("venv") / "fresh"
    _run([sys.executable, "-m", "venv", "--without-pip", v])
    deps = dict.fromkeys(p for p in sys.path if Path(p).name in ("site-packages", "dist-packages"))
    (_site(v) / "_citysynth_test_dependencies.pth").write_text("".join(f"{p}\n" for p in deps))
    _install(v, *wheels)
    return v


def test_the_wheel_holds_only_citysynth_and_its_data(wheels):
    names = zipfile.ZipFile(wheels[0]).namelist()
    version = importlib.metadata.version("citysynth")
    assert {n.split("/")[0] for n in names} == {"citysynth", f"citysynth-{version}.dist-info"}
    for shipped in ("citysynth/pipeline/cli.py", "citysynth/solver/structures/__init__.py",
                    "citysynth/examples/library/manifest.toml", "citysynth/examples/city/city.toml",
                    "citysynth/examples/street_front.json"):
        assert shipped in names, shipped
    manifest = zipfile.ZipFile(wheels[0]).read("citysynth/examples/library/manifest.toml")
    meshes = re.findall(rb'^file = "(.+)"', manifest, flags=re.M)
    assert meshes and all(f"citysynth/examples/library/{m.decode()}" in names for m in meshes)


def test_both_distributions_import_side_by_side(venv, tmp_path):
    code = ("import pipeline, export, export.fbx, citysynth.pipeline, citysynth.export\n"
            "import citysynth.pipeline.cli\n"
            "print(pipeline.NAME, export.NAME, export.fbx.write('x'), sep='|')\n"
            "print(citysynth.pipeline.__file__, citysynth.export.__file__, sep='|')")
    p = _run([venv / "bin" / "python", "-c", code], cwd=tmp_path, env=_env(tmp_path))
    studio, ours = p.stdout.splitlines()
    assert studio == "studio pipeline|studio export|fbx to x"
    site = _site(venv)
    assert ours.split("|") == [str(site / "citysynth" / "pipeline" / "__init__.py"),
                               str(site / "citysynth" / "export" / "__init__.py")]
    version = _run([venv / "bin" / "citysynth", "--version"], cwd=tmp_path, env=_env(tmp_path))
    assert version.stdout.split() == ["citysynth", importlib.metadata.version("citysynth")]


def test_demo_runs_from_an_empty_folder(venv, tmp_path):
    home, work = tmp_path / "home", tmp_path / "work"
    home.mkdir()
    work.mkdir()
    site = _site(venv)

    def files() -> set[Path]:
        return {p for p in site.rglob("*") if "__pycache__" not in p.parts}

    before = files()
    p = _run([venv / "bin" / "citysynth", "demo", "-o", "out"], cwd=work, env=_env(home))
    out = work / "out"
    # every file the demo says it wrote
    for name, n in re.findall(r"^(\w+): wrote (\d+) files", p.stdout, flags=re.M):
        written = [f for f in out.iterdir() if f.is_file()
                   and (f.name.startswith(name + ".") or f.name.startswith(name + "_"))]
        assert len(written) == int(n), (name, sorted(f.name for f in written))
    assert re.search(r"wrote out/city\.usda \(UsdValidation: clean\) and out/city\.png",
                     p.stdout), p.stdout[-2000:]
    # the progress line and the summary count the same skipped pieces
    shown = re.findall(r"skipped (\d+)", p.stderr.replace("\r", "\n"))
    told = re.search(r"(\d+) pieces skipped", p.stdout)
    assert shown and told and shown[-1] == told.group(1), (shown[-1:], p.stdout[-300:])
    for name in ("t_building_1.usda", "t_building_3.png", "block.usda", "block.glb",
                 "city.usda", "city.png", "manifest.json", "report.json"):
        assert (out / name).is_file(), name
    manifest = json.loads((out / "manifest.json").read_text())
    built = [b for b in manifest["blocks"].values() if b["status"] == "built"]
    assert built and all((out / f).is_file() for b in built for f in b["files"])
    # the sample library's database went to the user's cache folder, not site-packages
    assert list((home / ".cache" / "citysynth" / "partdb").glob("*/partdb.json"))
    assert files() == before


def test_uninstalling_either_leaves_the_other_whole(venv, wheels, tmp_path):
    site = _site(venv)
    version = importlib.metadata.version("citysynth")
    ours, studio = f"citysynth-{version}.dist-info", "studio_tools-1.0.dist-info"
    env = _env(tmp_path)
    py = venv / "bin" / "python"

    _pip(venv, "uninstall", "-y", "studio-tools")
    assert not (site / studio).exists() and _intact(site, ours) == []
    _run([py, "-c", "import citysynth.pipeline.cli, citysynth.export.usd"], cwd=tmp_path, env=env)
    _run([venv / "bin" / "citysynth", "--version"], cwd=tmp_path, env=env)

    _install(venv, wheels[1])
    _pip(venv, "uninstall", "-y", "citysynth")
    assert not (site / ours).exists() and _intact(site, studio) == []
    assert not (site / "citysynth" / "pipeline" / "cli.py").exists()
    p = _run([py, "-c", "import pipeline, export.fbx; print(pipeline.NAME, export.NAME)"],
             cwd=tmp_path, env=env)
    assert p.stdout.strip() == "studio pipeline studio export"
