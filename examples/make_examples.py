"""Regenerate the generated example problems (``make examples``); a test checks that
the files in the repository match what this writes."""

from __future__ import annotations

import json
from pathlib import Path

from pipeline.samples import street_front

HERE = Path(__file__).resolve().parent
GENERATED = {
    "street_front.json": lambda: street_front(83.4, k=5),
    "street_front_3res.json": lambda: street_front(60.0, resources=3, k=5),
}


def render(name: str) -> str:
    return json.dumps(GENERATED[name](), indent=1) + "\n"


def main() -> None:
    for name in GENERATED:
        (HERE / name).write_text(render(name), encoding="utf-8")
        print(f"wrote examples/{name}")


if __name__ == "__main__":
    main()
