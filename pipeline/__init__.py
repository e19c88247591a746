"""citysynth pipeline stage (see ../shared/DESIGN.md)."""
