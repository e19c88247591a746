"""Sample problems shipped with citysynth: the street front of the paper's Fig. 7, a
building like its Fig. 1(c) and block cycles (structures).

A street front filled with complete buildings: 74 buildings 4-20 m wide on the 0.2 m
grid, every transition allowed, seeded transition costs. The one-resource variant
asks for an exact length; the three-resource variant adds intervals on doors and
balconies that scale with the length. Deterministic for a given seed, so the demo,
the benchmark and ``examples/street_front.json`` agree.
"""

from __future__ import annotations

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


def block_cycle(corners: int = 40, *, seed: int = 1, k: int = 1) -> dict:
    """A closed block outline with ``corners`` corners (3 corner parts to choose from at
    each) and 20 facade parts, every transition allowed with seeded costs; side lengths
    of 30-80 m on the 0.2 m grid, each an equality."""
    rng = np.random.default_rng(seed)
    fill = [{"id": f"b{i}", "resources": {"length": round(0.2 * int(rng.integers(20, 101)), 1)}}
            for i in range(20)]
    keys = [{"id": f"c{i}", "legs": [{"length": 3.0 + 0.2 * i}, {"length": 3.0 + 0.2 * i}]}
            for i in range(3)]
    ids = [e["id"] for e in fill + keys]
    trans = [[a, b, float(np.round(rng.random(), 3))] for a in ids for b in ids]
    sides = [round(0.2 * int(rng.integers(150, 400)), 1) for _ in range(corners)]
    return {"resources": ["length"], "quantum": {"length": 0.2}, "elements": fill + keys,
            "transitions": trans, "keypoints": [{"elements": [x["id"] for x in keys]}] * corners,
            "stages": [{"constraints": {"length": [L, L]}} for L in sides], "closed": True,
            "k": k}
