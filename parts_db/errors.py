"""Errors a user can cause while ingesting a library (bad manifest, bad mesh, units).

The CLI prints the message and exits 2; nothing is written when one is raised."""


class LibraryError(ValueError):
    """The library cannot be ingested as it is; the message names the part and file."""
