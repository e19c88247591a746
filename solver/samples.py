"""Sample problems shipped with citysynth: the street front of the paper's Fig. 7, a
building like its Fig. 1(c), block cycles (structures) and a motion graph like the
one of the paper's Tables 2 and 3.

A street front filled with complete buildings: 74 buildings 4-20 m wide on the 0.2 m
grid, every transition allowed, seeded transition costs. The one-resource variant
asks for an exact length; the three-resource variant adds intervals on doors and
balconies that scale with the length. Deterministic for a given seed, so the demo,
the benchmark and ``examples/street_front.json`` agree.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any

import numpy as np

N_BUILDINGS = 74


def street_front(length_m: float, *, resources: int = 1, seed: int = 7, k: int = 1) -> dict:
    """The street-front problem as a problem dict (see ``solver.Problem.from_dict``)."""
    if resources not in (1, 3):
        raise ValueError("resources must be 1 or 3")
    rng = np.random.default_rng(seed)
    steps = np.sort(rng.choice(np.arange(20, 101), size=N_BUILDINGS, replace=False))
    doors = rng.integers(0, 3, size=N_BUILDINGS)
    balconies = rng.integers(0, 5, size=N_BUILDINGS)
    costs = np.round(rng.random((N_BUILDINGS, N_BUILDINGS)), 4)
    ids = [f"b{i:02d}_{s * 2 // 10}.{s * 2 % 10}m" for i, s in enumerate(steps)]
    names = ["length"] if resources == 1 else ["length", "doors", "balconies"]
    elements = []
    for i, s in enumerate(steps):
        res = {"length": round(float(s) * 0.2, 1)}
        if resources == 3:
            res["doors"] = int(doors[i])
            res["balconies"] = int(balconies[i])
        elements.append({"id": ids[i], "resources": res})
    transitions = [[ids[a], ids[b], float(costs[a, b])]
                   for a in range(N_BUILDINGS) for b in range(N_BUILDINGS)]
    L = round(float(length_m), 1)
    constraints: dict[str, list[float]] = {"length": [L, L]}
    if resources == 3:
        constraints["doors"] = [float(round(L / 25)), float(round(L / 12))]
        constraints["balconies"] = [float(round(L / 10)), float(round(L / 6))]
    return {"resources": names, "quantum": {"length": 0.2}, "elements": elements,
            "transitions": transitions, "constraints": constraints, "k": k}


def fig1c_like() -> dict:
    """A cycle of four corners with a wing at key point 1 whose end has a T of its own
    (nested T junctions hanging off a cycle), as in the paper's Fig. 1(c)."""
    fill: list[dict[str, Any]] = [{"id": f"m{L}", "resources": {"length": L}, "cost": 0.0}
                                  for L in (2, 3)]
    keys: list[dict[str, Any]] = [
        {"id": "corner", "legs": [{"length": 1}, {"length": 1}]},
        {"id": "corner_alt", "legs": [{"length": 1}, {"length": 1}], "cost": 0.25},
        {"id": "t_plain", "legs": [{"length": 1}, {"length": 1}, {"length": 1}]},
        {"id": "t_portal", "legs": [{"length": 1}, {"length": 1}, {"length": 1}],
         "cost": 0.125},
        {"id": "end", "legs": [{"length": 1}, {"length": 1}]},
    ]
    ids = [e["id"] for e in fill + keys]
    trans = [[a, b, 0.5 if a == b else 0.375 if (a, b) == ("m3", "m2") else 0.0]
             for a in ids for b in ids]
    btrans = [[a, b, 0.25] for a in ids for b in ids]
    T = ["t_plain", "t_portal"]
    return {
        "resources": ["length"], "elements": fill + keys, "transitions": trans,
        "branch_transitions": btrans,
        "keypoints": [{"elements": ["corner", "corner_alt"]},
                      {"elements": T, "branch": 4},
                      {"elements": ["corner", "corner_alt"]},
                      {"elements": ["corner", "corner_alt"]},
                      {"elements": T, "branch": 6},
                      {"elements": ["end"]}, {"elements": ["end"]}],
        "stages": [{"from": 0, "to": 1, "constraints": {"length": [7, 7]}},
                   {"from": 1, "to": 2, "constraints": {"length": [6, 6]}},
                   {"from": 2, "to": 3, "constraints": {"length": [9, 9]}},
                   {"from": 3, "to": 0, "constraints": {"length": [8, 8]}},
                   {"from": 1, "to": 4, "constraints": {"length": [6, 7]}},
                   {"from": 4, "to": 5, "constraints": {"length": [5, 5]}},
                   {"from": 4, "to": 6, "constraints": {"length": [4, 4]}}],
    }


def block_cycle(corners: int = 40, *, seed: int = 1, k: int = 1,
                doors: tuple[float, float] | None = None) -> dict:
    """A closed block outline with ``corners`` corners (3 corner parts to choose from at
    each) and 20 facade parts, every transition allowed with seeded costs; side lengths
    of 30-80 m on the 0.2 m grid, each an equality. ``doors``: a per-block
    (structure-wide) interval on the door count, about a third of the facade parts
    having a door."""
    rng = np.random.default_rng(seed)
    lengths = [{"length": round(0.2 * int(rng.integers(20, 101)), 1)} for i in range(20)]
    fill = [{"id": f"b{i}", "resources": r} for i, r in enumerate(lengths)]
    keys = [{"id": f"c{i}", "legs": [{"length": 3.0 + 0.2 * i}, {"length": 3.0 + 0.2 * i}]}
            for i in range(3)]
    ids = [str(e["id"]) for e in fill + keys]
    trans = [[a, b, float(np.round(rng.random(), 3))] for a in ids for b in ids]
    sides = [round(0.2 * int(rng.integers(150, 400)), 1) for _ in range(corners)]
    d: dict = {"resources": ["length"], "quantum": {"length": 0.2}, "elements": fill + keys,
         "transitions": trans, "keypoints": [{"elements": [x["id"] for x in keys]}] * corners,
         "stages": [{"constraints": {"length": [L, L]}} for L in sides], "closed": True,
         "k": k}
    if doors is not None:
        drng = np.random.default_rng(seed + 2)
        d["resources"] = ["length", "doors"]
        for r in lengths:
            r["doors"] = float(drng.random() < 0.3)
        d["constraints"] = {"doors": list(doors)}
    return d


MOTION_FPS = 30   # 5 m in 146 frames (paper, Table 3) is a walk at 30 frames a second


@lru_cache(maxsize=4)
def _motion_segments(n: int, successors: int, seed: int):
    """Segments (distance in 5 cm steps, frames, lateral drift) and, for each, its
    ``successors`` best-matching next segments with the pose distance."""
    rng = np.random.default_rng(seed)
    styles = rng.normal(size=(8, 4))                     # walking styles
    style = rng.integers(0, len(styles), n)
    frames = rng.integers(20, 61, n)
    speed = 0.85 + 0.08 * style + rng.normal(0.0, 0.08, n)   # m/s, per style
    steps = np.maximum(1, np.round(speed * frames / MOTION_FPS / 0.05)).astype(np.int64)
    period = 1.1 + 0.05 * rng.normal(size=n)             # gait cycle, seconds
    phase0 = rng.random(n) * 2 * np.pi
    phase1 = phase0 + 2 * np.pi * frames / (MOTION_FPS * period)
    body = styles[style] + rng.normal(0.0, 0.15, (n, 4))
    start = np.column_stack([body, np.cos(phase0), np.sin(phase0), speed])
    end = np.column_stack([body + rng.normal(0.0, 0.1, (n, 4)), np.cos(phase1),
                           np.sin(phase1), speed])
    heading = np.radians(rng.normal(0.0, 4.0, n))        # turn over the segment
    drift = 0.5 * steps * 0.05 * np.abs(np.sin(heading)) + rng.uniform(0.005, 0.03, n)
    succ = np.empty((n, successors), dtype=np.int64)
    cost = np.empty((n, successors))
    for a in range(0, n, 512):                           # pose distances, in blocks
        d = np.sqrt(((end[a:a + 512, None, :] - start[None, :, :]) ** 2).sum(axis=2))
        near = np.argpartition(d, successors, axis=1)[:, :successors]
        near.sort(axis=1)
        succ[a:a + 512] = near
        cost[a:a + 512] = np.take_along_axis(d, near, axis=1)
    return steps, frames, drift, succ, cost


def motion_graph(distance_m: float, frames: int | None = None, *, segments: int = 600,
                 successors: int = 32, alpha: float = 0.5, seed: int = 11,
                 k: int = 1) -> dict:
    """A synthetic motion graph shaped like the walk subset of HDM05 the paper times
    (Tables 2 and 3), as a problem dict: ``segments`` walking segments of 20-60 frames
    (at 30 frames a second) covering their distance in 5 cm steps, each followed only
    by the ``successors`` segments whose start pose best matches its end pose (the
    transition cost delta is that pose-feature distance, as a motion graph is built).
    The cost is eq. 4 of the paper, alpha * omega(e) + (1 - alpha) * delta(e, f), with
    omega the segment's mean distance from the path: the path is a straight line and
    every segment starts on it heading along it, so omega is its own lateral drift.
    Constraints: the distance exactly, and the frame count exactly when given
    (otherwise frames are only summed). ``segments=9709`` is HDM05's full size."""
    steps, nframes, drift, succ, cost = _motion_segments(segments, successors, seed)
    ids = [f"s{i:05d}" for i in range(segments)]
    elements = [{"id": ids[i], "resources": {"distance": round(0.05 * int(steps[i]), 2),
                                             "frames": int(nframes[i])},
                 "cost": alpha * float(drift[i])} for i in range(segments)]
    transitions = [[ids[a], ids[int(b)], (1 - alpha) * float(c)]
                   for a in range(segments)
                   for b, c in zip(succ[a], cost[a], strict=True)]
    D = round(float(distance_m), 2)
    constraints: dict[str, list[float]] = {"distance": [D, D]}
    if frames is not None:
        constraints["frames"] = [float(frames), float(frames)]
    return {"resources": ["distance", "frames"], "quantum": {"distance": 0.05},
            "elements": elements, "transitions": transitions, "constraints": constraints,
            "k": k}
