"""The reach of a structure-wide resource (solver.structures.solve._reach, which clips
an interval past it) found once per set of fillers and of key elements: the very
value of the per-stage, per-key-point sum it replaced, on generated structures and
on the benchmark's block with its per-block door interval."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings

from citysynth.solver.samples import block_cycle
from citysynth.solver.structures import Structure
from citysynth.solver.structures.decompose import stage_fillers
from citysynth.solver.structures.solve import _reach
from tests.test_structure_graphs import varied


def _reach_per_stage(st: Structure, r: str) -> float | None:
    """The sum as it was: every stage's fillers and every key point's legs anew."""
    total = 0.0
    for i, stage in enumerate(st.stages):
        amounts = [st.elements[e] for e in stage_fillers(st, i)]
        if any(a[r] < 0 for a in amounts):
            return None
        caps = [hi * max((a[r] / a[s] for a in amounts), default=0.0)
                for s, (_lo, hi) in stage.constraints.items()
                if math.isfinite(hi) and all(a[s] > 0 for a in amounts)]
        if not caps:
            return None
        total += min(caps)
    for candidates in st.keypoints:
        legs = [sum(leg[r] for leg in st.legs.get(e, ())) for e in candidates]
        if any(x < 0 for x in legs):
            return None
        total += max(legs, default=0.0)
    return total


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(varied())
def test_reach_found_once_per_fillers_is_the_per_stage_sum(d):
    s = Structure.from_dict(d)
    for r in s.resources:
        assert _reach(s, r) == _reach_per_stage(s, r)


def test_reach_of_the_benchmark_block():
    s = Structure.from_dict(block_cycle(40, doors=(20.0, 60.0)))
    for r in s.resources:
        assert _reach(s, r) == _reach_per_stage(s, r)
    assert _reach(s, "doors") is not None
