"""What an instance shows: its part's pieces, or (at a mitre joint or a fold) the
part cut as its :class:`~citysynth.export.layout.Cut` says. Every writer (USD, glTF,
previews) takes an instance's geometry from here, so all show the same prototype."""

from __future__ import annotations

from citysynth.export.cuts import cut_pieces
from citysynth.export.layout import Instance
from citysynth.parts_db import PartDB
from citysynth.parts_db.geometry import Piece, part_pieces


def prototype_pieces(db: PartDB, inst: Instance) -> tuple[Piece, ...]:
    """The pieces ``inst`` shows, in its part's placement frame."""
    part = db.part(inst.part)
    if inst.cut is None:
        return part_pieces(db, part)
    return cut_pieces(db, part, inst.cut)
