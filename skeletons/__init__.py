"""citysynth skeletons: street networks, footprints and building skeletons (GeoJSON)
-> skeletons of key points and edges in a local metric frame.

``read_geojson`` projects the input (lon/lat, or any CRS a GIS tool writes; features
it cannot use are left out with an ``InputWarning``); ``skeleton_from_lines`` (building skeletons),
``skeletons_from_polygons`` (footprints, blocks; one cycle per ring) and
``blocks_from_streets`` (centre lines -> inset blocks) build the skeletons. This
package knows nothing of part libraries or the solver.
"""

from typing import TYPE_CHECKING

from citysynth.skeletons.errors import InputWarning, SkeletonError
from citysynth.solver.exports import lazy_exports

# shapely and pyproj load only when one of these names is first used
if TYPE_CHECKING:   # what type checkers and editors read
    from citysynth.skeletons.angles import match_corner_angles as match_corner_angles
    from citysynth.skeletons.from_geometry import blocks_from_streets as blocks_from_streets
    from citysynth.skeletons.from_geometry import describe as describe
    from citysynth.skeletons.from_geometry import skeleton_from_lines as skeleton_from_lines
    from citysynth.skeletons.from_geometry import (
        skeletons_from_polygons as skeletons_from_polygons,
    )
    from citysynth.skeletons.geojson import Feature as Feature
    from citysynth.skeletons.geojson import Features as Features
    from citysynth.skeletons.geojson import Frame as Frame
    from citysynth.skeletons.geojson import lonlat_from_local as lonlat_from_local
    from citysynth.skeletons.geojson import parse_geojson as parse_geojson
    from citysynth.skeletons.geojson import read_geojson as read_geojson
    from citysynth.skeletons.model import Edge as Edge
    from citysynth.skeletons.model import Front as Front
    from citysynth.skeletons.model import KeyPoint as KeyPoint
    from citysynth.skeletons.model import KeyPointKind as KeyPointKind
    from citysynth.skeletons.model import Skeleton as Skeleton
else:   # what runs: the same names, imported when first used (solver.exports)
    __getattr__, __dir__, _lazy = lazy_exports(__name__, {
        "angles": ("match_corner_angles",),
        "from_geometry": ("blocks_from_streets", "describe", "skeleton_from_lines",
                          "skeletons_from_polygons"),
        "geojson": ("Feature", "Features", "Frame", "lonlat_from_local", "parse_geojson",
                    "read_geojson"),
        "model": ("Edge", "Front", "KeyPoint", "KeyPointKind", "Skeleton"),
    })
    __all__ = ["InputWarning", "SkeletonError", *_lazy]
