"""citysynth skeletons: street networks, footprints and building skeletons (GeoJSON)
-> skeletons of key points and edges in a local metric frame.

``read_geojson`` projects the input (lon/lat, or any CRS a GIS tool writes; features
it cannot use are left out with an ``InputWarning``); ``skeleton_from_lines`` (building skeletons),
``skeletons_from_polygons`` (footprints, blocks; one cycle per ring) and
``blocks_from_streets`` (centre lines -> inset blocks) build the skeletons. This
package knows nothing of part libraries or the solver.
"""

from citysynth.skeletons.angles import match_corner_angles
from citysynth.skeletons.errors import SkeletonError
from citysynth.skeletons.from_geometry import (
    blocks_from_streets,
    describe,
    skeleton_from_lines,
    skeletons_from_polygons,
)
from citysynth.skeletons.geojson import (
    Feature,
    Features,
    Frame,
    InputWarning,
    lonlat_from_local,
    parse_geojson,
    read_geojson,
)
from citysynth.skeletons.model import Edge, Front, KeyPoint, KeyPointKind, Skeleton

__all__ = ["Edge", "Feature", "Features", "Frame", "Front", "InputWarning", "KeyPoint",
           "KeyPointKind", "Skeleton", "SkeletonError",
           "blocks_from_streets", "describe", "lonlat_from_local", "match_corner_angles",
           "parse_geojson",
           "read_geojson",
           "skeleton_from_lines", "skeletons_from_polygons"]
