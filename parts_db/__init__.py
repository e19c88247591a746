"""citysynth parts_db stage (see ../shared/DESIGN.md)."""
