"""citysynth skeletons stage (see ../shared/DESIGN.md)."""
