"""Structures (paper §3.2): the model (:mod:`.model`), the solver
(:mod:`.solve`), its shared stage graphs (:mod:`.stage_graphs`, kernels in
:mod:`.stage_kbest`), the k-best combining program (:mod:`.combine`) and the
reference method by decomposition (:mod:`.decompose`)."""

from citysynth.solver.structures.model import Stage, Structure
from citysynth.solver.structures.solve import (
    METHODS,
    StructureResult,
    StructureSolution,
    solve_structure,
)

__all__ = ["METHODS", "Stage", "Structure", "StructureResult", "StructureSolution",
           "solve_structure"]
