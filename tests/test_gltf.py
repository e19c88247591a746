"""glTF as engines take it: every GLB passes Khronos's glTF Validator (the npm package
``gltf-validator``, which ``make test`` installs into build/node and this module installs
itself when it is missing) with no error and no warning, stands Y-up (ground on y = 0,
height along +Y, a rotation from the layout frame, not a mirror), names its nodes for
their parts and carries the layout's facts in ``extras``; one material per library
material; a city GLB of several layouts on request; bytes the same on every run."""

from __future__ import annotations

import json
import shutil
import struct
import subprocess
from pathlib import Path

import numpy as np
import pytest
import trimesh

from citysynth.export.assemble import bounds
from citysynth.export.gltf import IDENTITY, write_city_glb, write_glb
from citysynth.export.layout import Layout
from citysynth.export.materials import material_name
from citysynth.export.prototypes import prototype_pieces
from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
T_BUILDING = ROOT / "examples" / "skeletons" / "t_building.geojson"
BLOCK = ROOT / "examples" / "blocks" / "block.geojson"
NODE_DIR = ROOT / "build" / "node"
VALIDATOR_VERSION = "2.0.0-dev.3.10"   # the Makefile's pin
SCRIPT = Path(__file__).with_name("gltf_validate.cjs")


def ensure_validator() -> Path:
    """build/node/node_modules with gltf-validator in it, installed with npm when
    missing (as the Makefile's rule does)."""
    modules = NODE_DIR / "node_modules"
    if not (modules / "gltf-validator" / "package.json").is_file():
        npm = shutil.which("npm")
        assert npm, "npm is needed to install Khronos's gltf-validator (node 20 and npm)"
        NODE_DIR.mkdir(parents=True, exist_ok=True)
        subprocess.run([npm, "install", "--prefix", str(NODE_DIR), "--no-audit", "--no-fund",
                        "--silent", f"gltf-validator@{VALIDATOR_VERSION}"],
                       check=True, timeout=600)
    return modules


def validate_glbs(paths: list[Path]) -> list[dict]:
    """Khronos's validator on each GLB: its report summary (issue counts, messages)."""
    assert paths, "no GLB to validate"
    node = shutil.which("node")
    assert node, "node is needed to run Khronos's gltf-validator"
    p = subprocess.run([node, str(SCRIPT), str(ensure_validator()), *map(str, paths)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return [json.loads(line) for line in p.stdout.splitlines()]


def assert_clean(paths: list[Path]) -> None:
    for report in validate_glbs(paths):
        assert report["errors"] == 0 and report["warnings"] == 0, report


def glb_json(path: Path) -> dict:
    data = path.read_bytes()
    magic, version, total = struct.unpack_from("<4sII", data)
    assert (magic, version, total) == (b"glTF", 2, len(data))
    length, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON"
    return json.loads(data[20:20 + length])


@pytest.fixture
def db(sample_db):
    return sample_db


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("gltf")
    assert main(["building", str(T_BUILDING), "--library", str(LIB), "--style", "classic",
                 "--k", "3", "-o", str(out), "--no-preview"]) == 0
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "-o", str(out), "--no-preview"]) == 0
    return out


def _layouts(out: Path) -> list[tuple[Path, Layout]]:
    return [(p.with_name(p.name.replace(".layout.json", ".glb")),
             Layout.from_dict(json.loads(p.read_text())))
            for p in sorted(out.glob("*.layout.json"))]


def test_every_glb_passes_khronos_validator(run_dir):
    paths = sorted(run_dir.glob("*.glb"))
    assert len(paths) == 4
    assert_clean(paths)


def test_a_broken_glb_fails_the_validator(run_dir, tmp_path):
    """The check can fail: a file whose accessor claims wrong bounds is reported."""
    src = run_dir / "block.glb"
    data = bytearray(src.read_bytes())
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    # bounds below the data (short numbers: the chunk keeps its length, padded)
    doc["accessors"][0]["max"] = [-1000.0] * len(doc["accessors"][0]["max"])
    text = json.dumps(doc, sort_keys=True, separators=(",", ":")).encode()
    text += b" " * (length - len(text))
    assert len(text) == length
    data[20:20 + length] = text
    bad = tmp_path / "bad.glb"
    bad.write_bytes(bytes(data))
    (report,) = validate_glbs([bad])
    assert report["errors"] > 0


def test_glb_is_y_up_with_the_ground_at_zero(run_dir, db):
    for glb, lay in _layouts(run_dir):
        scene = trimesh.load(str(glb))
        (lo, hi) = bounds(lay, db)            # layout frame: Z up
        want = np.array([[lo[0], lo[2], -hi[1]], [hi[0], hi[2], -lo[1]]])
        np.testing.assert_allclose(scene.bounds, want, atol=2e-3)
        assert abs(scene.bounds[0][1]) < 1e-6 and scene.bounds[1][1] > 5.0
        root = glb_json(glb)["nodes"][glb_json(glb)["scenes"][0]["nodes"][0]]
        x, y, z, w = root["rotation"]
        rot = trimesh.transformations.quaternion_matrix([w, x, y, z])[:3, :3]
        assert np.linalg.det(rot) == pytest.approx(1.0)   # a rotation: handedness kept
        np.testing.assert_allclose(rot @ [0, 0, 1], [0, 1, 0], atol=1e-12)


def test_nodes_named_for_parts_with_layout_facts_in_extras(run_dir, db):
    for glb, lay in _layouts(run_dir):
        doc = glb_json(glb)
        root = doc["nodes"][doc["scenes"][0]["nodes"][0]]
        facts = root["extras"]["citysynth"]
        assert facts["rank"] == lay.rank and facts["cost"] == pytest.approx(lay.cost)
        assert facts["parts_used"] == lay.parts_used() and facts["constraints_met"] is True
        assert facts["georeference"]["origin_lon"] == pytest.approx(7.1, abs=0.1)
        inst = [n for n in doc["nodes"] if "part" in n.get("extras", {}).get("citysynth", {})]
        assert [n["extras"]["citysynth"]["part"] for n in inst] == \
            [i.part for i in lay.instances]
        assert all(n["name"].startswith(n["extras"]["citysynth"]["part"]) for n in inst)
        stages = {n["name"] for n in doc["nodes"] if n["name"].startswith("stage_")}
        assert stages == {f"stage_{i.stage:02d}" for i in lay.instances if i.stage is not None}
        # one material per library material (kind and colour), shared by every mesh
        want = {material_name(p) for i in lay.instances for p in prototype_pieces(db, i)}
        names = [m["name"] for m in doc["materials"]]
        assert len(names) == len(set(names)) and set(names) == want


def test_glb_bytes_are_deterministic(run_dir, db, tmp_path):
    assert main(["block", str(BLOCK), "--library", str(LIB), "--style", "modern",
                 "-o", str(tmp_path), "--no-preview"]) == 0
    assert (tmp_path / "block.glb").read_bytes() == (run_dir / "block.glb").read_bytes()
    _glb, lay = _layouts(run_dir)[0]
    a = write_glb(lay, db, tmp_path / "a.glb").read_bytes()
    assert a == write_glb(lay, db, tmp_path / "b.glb").read_bytes()


def test_city_glb_holds_every_layout_and_validates(run_dir, db, tmp_path):
    lays = _layouts(run_dir)
    city = write_city_glb(tmp_path / "city.glb",
                          [(glb.stem, lay, db) for glb, lay in lays], extras={"blocks": 4})
    assert_clean([city])
    doc = glb_json(city)
    root = doc["nodes"][doc["scenes"][0]["nodes"][0]]
    assert [doc["nodes"][c]["name"] for c in root["children"]] == [g.stem for g, _ in lays]
    n = sum(1 for node in doc["nodes"] if "part" in node.get("extras", {}).get("citysynth", {}))
    assert n == sum(len(lay.instances) for _g, lay in lays)
    # meshes of one library are shared across layouts: each prototype once
    protos = {i.proto for _g, lay in lays for i in lay.instances}
    shared = [m for m in doc["meshes"] if "@" not in m["name"]]   # not a baked shear
    assert len(shared) == len({m["name"] for m in shared}) <= len(protos)


def test_a_tower_glb_has_no_validator_infos(tmp_path):
    """A tower's parts stand at the identity (a tower is its own frame): the node wrote
    the default matrix, and the validator reported NODE_MATRIX_DEFAULT (an info; the
    matrices also held -0.0). Nodes at the identity now carry no matrix."""
    assert main(["tower", "--height", "40", "--far", "4", "--lot-area", "400", "--k", "1",
                 "-o", str(tmp_path), "--no-preview"]) == 0
    (path,) = sorted(tmp_path.glob("*.glb"))
    (report,) = validate_glbs([path])
    assert report["errors"] == report["warnings"] == report["infos"] == 0, report
    doc = glb_json(path)
    matrices = [n["matrix"] for n in doc["nodes"] if "matrix" in n]
    assert all(m != IDENTITY for m in matrices)
    assert "-0.0" not in json.dumps(matrices)
    assert sum("mesh" in n for n in doc["nodes"]) > 3
