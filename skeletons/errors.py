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
