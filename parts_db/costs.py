"""The transition-cost table: how well part f fits after part e.

Cost (paper eq. 3, as area): the area where the out-section of e and the in-section of
f disagree (their symmetric difference), plus class rules for what may follow what.
Parts in different groups (facade parts, complete buildings, tower floors) never
follow each other. Sections shared by many parts are compared once.
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import shapely

from citysynth.parts_db.manifest import PartClass
from citysynth.parts_db.sections import disagreement

GROUPS: dict[PartClass, str] = {
    "end_left": "facade", "middle": "facade", "corner": "facade", "t_junction": "facade",
    "end_right": "facade", "building": "building",
    "ground_floor": "tower", "floor": "tower", "roof": "tower",
}
FIRST_ONLY: set[PartClass] = {"end_left", "ground_floor"}   # nothing may precede these
LAST_ONLY: set[PartClass] = {"end_right", "roof"}           # nothing may follow these


def allowed_matrix(classes: list[PartClass]) -> np.ndarray:
    """allowed[e, f]: may f directly follow e (class rules only)."""
    g = np.array([GROUPS[c] for c in classes])
    first = np.array([c in FIRST_ONLY for c in classes])
    last = np.array([c in LAST_ONLY for c in classes])
    return (g[:, None] == g[None, :]) & ~last[:, None] & ~first[None, :]


CHUNK_PAIRS = 1 << 22   # (part, part) pairs a step of cost_matrix looks at


def cost_matrix(out_secs: list, in_secs: list, allowed: np.ndarray) -> np.ndarray:
    """cost[e, f] = area(out_e xor in_f) where allowed, else inf. The table is filled a
    band of rows at a time, each pair named by one integer (its out- and in-section's),
    never listed as Python objects: the pairs of a 15,000-part library as lists took
    3.4 GB beside the table, and ingest died of it."""
    n = len(out_secs)
    cost = np.full((n, n), np.inf)
    uo, io = _unique(out_secs)
    ui, ii = _unique(in_secs)
    rows = range(0, n, max(1, CHUNK_PAIRS // max(n, 1)))
    step = rows.step

    def codes(a: int) -> np.ndarray:   # each allowed pair of rows a.. as out * |in| + in
        return (io[a:a + step, None] * len(ui) + ii[None, :])[allowed[a:a + step]]

    seen = np.unique(np.concatenate([np.unique(codes(a)) for a in rows] or [np.empty(0, int)]))
    if len(seen) == 0:
        return cost
    pairs = np.stack([seen // len(ui), seen % len(ui)], axis=1)   # sorted as before
    # rounded to 1 cm²: below that the difference is the noise of cutting meshes
    areas = np.round(_areas(uo, ui, pairs), 4)
    for a in rows:
        cost[a:a + step][allowed[a:a + step]] = areas[np.searchsorted(seen, codes(a))]
    return cost


PAIRS_PER_WORKER = 20_000  # below this a process pool costs more than it saves


def _areas(uo: np.ndarray, ui: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    """Disagreement areas of the given (out, in) index pairs; big tables on all cores
    (the sections travel as WKB, each worker rebuilds them once)."""
    workers = min(os.cpu_count() or 1, len(pairs) // PAIRS_PER_WORKER)
    if workers <= 1:
        return disagreement(uo[pairs[:, 0]], ui[pairs[:, 1]])
    wo = shapely.to_wkb(uo)
    wi = shapely.to_wkb(ui)
    chunks = np.array_split(pairs, workers * 4)
    with ProcessPoolExecutor(workers) as pool:
        parts = pool.map(_areas_job, [(wo, wi, c) for c in chunks])
        return np.concatenate(list(parts))


def _areas_job(job) -> np.ndarray:
    wo, wi, pairs = job
    uo, ui = shapely.from_wkb(wo), shapely.from_wkb(wi)
    return disagreement(uo[pairs[:, 0]], ui[pairs[:, 1]])


def _unique(geoms: list):
    """Distinct geometries (by WKB) and the index of each input among them."""
    keys = [shapely.to_wkb(g) for g in geoms]
    first: dict[bytes, int] = {}
    inv = np.array([first.setdefault(k, len(first)) for k in keys], dtype=np.int64)
    uniq = np.empty(len(first), dtype=object)
    for k, i in first.items():
        uniq[i] = shapely.from_wkb(k)
    return uniq, inv
