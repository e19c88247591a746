"""The ingest summary printed by ``citysynth ingest``: parts per class and style,
length and height ranges, transition-cost statistics and warnings."""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from citysynth.parts_db.library import PartDB


def summary(db: PartDB, seconds: float | None = None) -> str:
    how = "cache hit" if db.cache_hit else "ingested"
    if seconds is not None:
        how += f" in {seconds:.2f} s"
    lines = [f'library "{db.name}": {len(db.parts)} parts, quantum {db.quantum:g} m, '
             f"hash {db.library_hash[:12]} ({how})", ""]
    groups: dict[tuple[str, str], list] = defaultdict(list)
    for p in db.parts:
        groups[(p.cls, p.style)].append(p)
    head = f"{'class':<13} {'style':<9} {'parts':>5}  {'length m':>13}  {'height m':>11}"
    lines += [head, "-" * len(head)]
    for (cls, style), ps in sorted(groups.items()):
        lens = [p.length for p in ps]
        hs = [p.height for p in ps]
        lines.append(f"{cls:<13} {style:<9} {len(ps):>5}  {min(lens):>5.1f} – {max(lens):<5.1f}"
                     f"  {min(hs):>4.1f} – {max(hs):<4.1f}")
    finite = db.cost[np.isfinite(db.cost)]
    lines.append("")
    snap, who = max(((max(abs(a - b) for a, b in zip(p.legs, p.legs_measured, strict=True)),
                      p.id) for p in db.parts), default=(0.0, ""))
    lines.append(f"largest change from snapping to the {db.quantum:g} m grid: {snap:.3f} m"
                 + (f" ({who})" if snap > 1e-9 else ""))
    if len(finite):
        lines.append(f"transition costs (section disagreement, m²): {len(finite):,} allowed "
                     f"pairs; min {finite.min():.2f}, median {np.median(finite):.2f}, "
                     f"max {finite.max():.2f}")
    else:
        lines.append("transition costs: no allowed pairs")
    if db.warnings:
        lines.append(f"warnings ({len(db.warnings)}):")
        lines += [f"  {w}" for w in db.warnings]
    else:
        lines.append("warnings: none")
    if db.path is not None:
        lines.append(f"database: {db.path}")
    return "\n".join(lines)
