"""Build one footprint with ``citysynth city`` (k = 1, the best layout, one worker) and
hand back its layout USD and JSON, for tests that audit a building's geometry."""

from __future__ import annotations

import json
from pathlib import Path

from citysynth.pipeline.cli import main

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
HELSINKI = ROOT / "examples" / "city" / "district_buildings.geojson"
DEPTH = 14.0             # the sample library's building depth


def helsinki_feature(n: int) -> dict:
    """Feature ``n`` of the shipped Helsinki footprints."""
    return json.loads(HELSINKI.read_text())["features"][n]


def build_feature(tmp_path: Path, feature: dict, config: str = "") -> tuple[Path, dict]:
    """The built block's layout USD and its layout JSON (parsed); ``config``: more of
    the city.toml."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    fp = tmp_path / "b.geojson"
    fp.write_text(json.dumps({"type": "FeatureCollection", "features": [feature]}))
    cfg = tmp_path / "c.toml"
    cfg.write_text('k = 1\npick = "best"\n' + config)
    out = tmp_path / "run"
    assert main(["city", "--footprints", str(fp), "--library", str(LIB), "-o", str(out),
                 "--config", str(cfg), "--workers", "1", "--no-overview"]) == 0
    ((bid, rec),) = json.loads((out / "manifest.json").read_text())["blocks"].items()
    assert rec["status"] == "built", rec
    return out / "blocks" / f"{bid}.usda", json.loads(
        (out / "blocks" / f"{bid}.layout.json").read_text())
