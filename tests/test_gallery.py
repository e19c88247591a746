"""``citysynth gallery``: the paper's figures rendered from the sample library (two of
them here, the whole set in the README's docs/gallery), the close-up sheet of joints,
and a wrong figure name."""

from __future__ import annotations

from PIL import Image

from citysynth import examples
from citysynth.parts_db import load_library
from citysynth.pipeline.cli import main
from citysynth.pipeline.commands.gallery_figures import FIGURES
from citysynth.pipeline.commands.gallery_joints import (
    JOINTS,
    STYLES,
    TILE,
    joint_label,
    solve_joint,
)


def test_gallery_writes_the_asked_figures(tmp_path, capsys):
    # a figure asked twice is made once (it was rendered twice)
    assert main(["gallery", "--only", "fig4", "fig7", "fig4", "-o", str(tmp_path)]) == 0
    assert capsys.readouterr().out.count("fig4.png") == 1
    for name in ("fig4", "fig7"):
        img = Image.open(tmp_path / f"{name}.png").convert("RGB")
        assert img.size == (1400, 700)
        assert len(img.getcolors(1 << 20) or []) > 50        # a rendering, not a blank
    assert sorted(p.stem for p in tmp_path.glob("*.png")) == ["fig4", "fig7"]
    assert set(FIGURES) == {"fig1c", "fig1d", "fig4", "fig5", "fig6", "fig7", "fig8",
                            "complex"}


def test_gallery_joints_sheet(tmp_path, capsys):
    """``--only joints`` writes the close-up sheet alone: one tile per style and joint
    kind, each panel a rendering (many colours), labelled with what the joint got."""
    assert main(["gallery", "--only", "joints", "-o", str(tmp_path)]) == 0
    assert [p.name for p in tmp_path.glob("*.png")] == ["joints.png"]
    img = Image.open(tmp_path / "joints.png").convert("RGB")
    cols, styles = len(JOINTS), len(STYLES)
    assert img.size == (cols * TILE[0], styles * (TILE[1] + TILE[1] // 2))
    tile_h = img.size[1] // styles
    for r in range(styles):
        for c in range(cols):
            close_up = img.crop((c * TILE[0], r * tile_h, (c + 1) * TILE[0],
                                 r * tile_h + TILE[1]))
            assert len(close_up.getcolors(1 << 20) or []) > 50, (r, c)
    assert "joints.png  (12 layout(s)" in capsys.readouterr().out


def test_joint_labels_say_what_each_joint_got():
    """The sheet's inputs give what their labels promise: the 30° corner a nose, the
    off-library angles mitres, the right angle a library corner part, the bend a module
    folded across it, the T a T part."""
    db = load_library(examples.SAMPLE_LIBRARY)
    got = {j.kind: joint_label(solve_joint(db, j, "modern"), j.at) for j in JOINTS}
    assert got["acute convex 30°"] == "nose"
    assert got["obtuse convex 140°"] == got["concave 95°"] == "mitre"
    assert got["right convex 90°"].startswith("part modern_corner_90_convex")
    assert got["bend 20°"] == "module folded across it"
    assert got["T junction"].startswith("part modern_t")


def test_gallery_unknown_figure_is_a_usage_error(tmp_path, capsys):
    assert main(["gallery", "--only", "fig9", "-o", str(tmp_path)]) == 2
    assert "no figure fig9" in capsys.readouterr().err
