"""Errors a layout or an export can raise for user input (exit code 2 at the CLI)."""


class ExportError(ValueError):
    """A layout fails a geometric check, or an output cannot be written; the message
    names the structure, the place and the fix."""
