"""Sample problems shipped with citysynth: the street front of the paper's Fig. 7.

A street front filled with complete buildings: 74 buildings 4-20 m wide on the 0.2 m
grid, every transition allowed, seeded transition costs. The one-resource variant
asks for an exact length; the three-resource variant adds intervals on doors and
balconies that scale with the length. Deterministic for a given seed, so the demo,
the benchmark and ``examples/street_front.json`` agree.
"""

from __future__ import annotations

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
