"""Errors a user can cause with skeleton input (malformed GeoJSON, bad geometry).

The CLI prints the message and exits 2; every message names the feature."""


class SkeletonError(ValueError):
    """The input cannot be turned into structures; the message says where and why."""
