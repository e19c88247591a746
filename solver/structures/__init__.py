"""Structures (paper §3.2): the model (:mod:`.model`), the solver
(:mod:`.solve`), its shared stage graphs (:mod:`.stage_graphs`, kernels in
:mod:`.stage_kbest`), the k-best combining program (:mod:`.combine`) and the
reference method by decomposition (:mod:`.decompose`)."""

from typing import TYPE_CHECKING

from citysynth.solver.exports import lazy_exports

# the stage kernels load only when one of these names is first used
if TYPE_CHECKING:   # what type checkers and editors read
    from citysynth.solver.structures.model import Stage as Stage
    from citysynth.solver.structures.model import Structure as Structure
    from citysynth.solver.structures.solve import METHODS as METHODS
    from citysynth.solver.structures.solve import StructureResult as StructureResult
    from citysynth.solver.structures.solve import StructureSolution as StructureSolution
    from citysynth.solver.structures.solve import solve_structure as solve_structure
else:   # what runs: the same names, imported when first used (solver.exports)
    __getattr__, __dir__, __all__ = lazy_exports(__name__, {
        "model": ("Stage", "Structure"),
        "solve": ("METHODS", "StructureResult", "StructureSolution", "solve_structure"),
    })
