"""Names an artist reads in a DCC's outliner, the same in USD and glTF: a group per
structure (``structure_00``), in it one per stage (``stage_03``) and one for the key
points (``keys``), and each part instance named for its part and its place
(``classic_mid_5.2_4s_07``: the stage's eighth part; ``classic_corner_90_k02``: the
part at key point 2, ``_k02_1`` for the second leg of a mitre there), and a
footprint's roof infill beside the structures (``infill_00``). Deterministic:
a function of the layout's instance order only. And the one layout fact both
writers compute rather than copy: whether every asked constraint is met."""

from __future__ import annotations

from citysynth.export.layout import Instance, Layout


def structure_group(structure: int) -> str:
    return f"structure_{structure:02d}"


INFILL = "infill_"


def infill_name(n: int) -> str:
    """The name of a layout's n-th roof infill (USD prim, glTF node): ``infill_00``."""
    return f"{INFILL}{n:02d}"


def stage_group(inst: Instance) -> str:
    return "keys" if inst.stage is None else f"stage_{inst.stage:02d}"


def instance_labels(lay: Layout) -> list[str]:
    """One label per instance of ``lay``, unique within its (structure, stage) group."""
    counters: dict[tuple, int] = {}
    labels = []
    for inst in lay.instances:
        group = (inst.structure, inst.stage, inst.key if inst.stage is None else None)
        n = counters.get(group, 0)
        counters[group] = n + 1
        if inst.stage is not None:
            labels.append(f"{inst.part}_{n:02d}")
        else:
            labels.append(f"{inst.part}_k{inst.key:02d}" + (f"_{n}" if n else ""))
    return labels


def constraints_met(lay: Layout) -> bool:
    """Whether every resource each stage and structure asked for lies in its bounds
    (the solver guarantees it; a DCC user reads it without trusting that)."""
    eps = 1e-6
    checks = [(st.get("asked", {}), st.get("resources", {})) for st in lay.structures]
    checks += [(sg["asked"], sg["met"]) for st in lay.structures for sg in st["stages"]]
    return all((lo is None or lo - eps <= met.get(r, 0.0))
               and (hi is None or met.get(r, 0.0) <= hi + eps)
               for asked, met in checks for r, (lo, hi) in asked.items())
