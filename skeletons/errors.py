"""Errors a user can cause with skeleton input (malformed GeoJSON, bad geometry), and
the warning for what of it is left out.

The CLI prints the message and exits 2; every message names the feature."""


class SkeletonError(ValueError):
    """The input cannot be turned into structures; the message says where and why."""


class InputWarning(UserWarning):
    """Something in the input was left out (a feature) or overridden (its CRS member);
    the message names the file, what and why."""


class FarFromFrame(SkeletonError):
    """Data lie so far east or west of the run's frame centre that the frame would
    stretch them past use (``reach``: how far, as a message says it). A city's zone
    polygon far from the streets is told apart from the data being so (see
    ``pipeline.city.run``)."""

    def __init__(self, message: str, reach: str) -> None:
        super().__init__(message)
        self.reach = reach


class FarFromFrameWarning(InputWarning):
    """Data far enough from the run's frame centre to be stretched visibly, not past
    use (``reach``: how far)."""

    def __init__(self, message: str, reach: str) -> None:
        super().__init__(message)
        self.reach = reach


_DAMAGE = (   # what GDAL, SQLite and Arrow say of a damaged file, in a user's words
    (("file is not a database", "database disk image is malformed",
      "file is encrypted or is not a database"),
     "its database is damaged, or it is not one (cut short, or another kind of file "
     "renamed)"),
    (("magic bytes not found", "Parquet file size is 0", "Couldn't deserialize thrift"),
     "it is cut short, or not a Parquet file (its end holds no table of contents)"),
    (("Fatal error parsing feature", "Unexpected end of file", "file is truncated"),
     "it ends part-way through its features (cut short or damaged)"),
)


def cannot_read(path: object, fmt: str, detail: str, whole: str = "") -> SkeletonError:
    """A GIS file its reader refused: what is wrong in plain words where the reader's
    are known to mean a damaged file (they were given in brackets: "(database disk
    image is malformed)", "(Parquet magic bytes not found in footer. Either the file
    is corrupted or this is not a parquet file.)"), else the reader's own; ``whole``
    names the files it needs beside it."""
    plain = next((words for phrases, words in _DAMAGE
                  if any(p.lower() in detail.lower() for p in phrases)), None)
    what = f": {plain}" if plain else f" ({detail})"
    return SkeletonError(f"{path}: cannot read this {fmt}{what}; check that it is "
                         f"whole{whole}, or export the layer as GeoJSON")
