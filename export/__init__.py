"""citysynth export stage (see ../shared/DESIGN.md)."""
