"""citysynth part libraries: segmented building-part meshes -> a part database.

``load_library(path)`` returns a :class:`PartDB` (ingesting and caching as needed);
``ingest(path, out)`` forces the choice of output. See the README, "Part libraries".
This package knows nothing of skeletons or the solver.
"""

from typing import TYPE_CHECKING

from citysynth.parts_db.errors import LibraryError
from citysynth.solver.exports import lazy_exports

# trimesh and the measuring code load only when one of these names is first used
if TYPE_CHECKING:   # what type checkers and editors read
    from citysynth.parts_db.library import Part as Part
    from citysynth.parts_db.library import PartDB as PartDB
    from citysynth.parts_db.library import ingest as ingest
    from citysynth.parts_db.library import load_db as load_db
    from citysynth.parts_db.library import load_library as load_library
    from citysynth.parts_db.manifest import CLASSES as CLASSES
    from citysynth.parts_db.manifest import PartClass as PartClass
else:   # what runs: the same names, imported when first used (solver.exports)
    __getattr__, __dir__, _lazy = lazy_exports(__name__, {
        "library": ("Part", "PartDB", "ingest", "load_db", "load_library"),
        "manifest": ("CLASSES", "PartClass"),
    })
    __all__ = ["LibraryError", *_lazy]
