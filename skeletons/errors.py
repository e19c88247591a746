"""Errors a user can cause with skeleton input (malformed GeoJSON, bad geometry), and
the warning for what of it is left out.

The CLI prints the message and exits 2; every message names the feature."""


class SkeletonError(ValueError):
    """The input cannot be turned into structures; the message says where and why."""


class InputWarning(UserWarning):
    """Something in the input was left out (a feature) or overridden (its CRS member);
    the message names the file, what and why."""
