"""citysynth part libraries: segmented building-part meshes -> a part database.

``load_library(path)`` returns a :class:`PartDB` (ingesting and caching as needed);
``ingest(path, out)`` forces the choice of output. See the README, "Part libraries".
This package knows nothing of skeletons or the solver.
"""

from citysynth.parts_db.errors import LibraryError
from citysynth.parts_db.library import Part, PartDB, ingest, load_db, load_library
from citysynth.parts_db.manifest import CLASSES, PartClass

__all__ = ["CLASSES", "LibraryError", "Part", "PartClass", "PartDB", "ingest", "load_db",
           "load_library"]
