"""``citysynth gallery``: the paper's figures rendered from the sample library (two of
them here, the whole set in the README's docs/gallery), and a wrong figure name."""

from __future__ import annotations

from PIL import Image

from citysynth.pipeline.cli import main
from citysynth.pipeline.commands.gallery import FIGURES


def test_gallery_writes_the_asked_figures(tmp_path, capsys):
    assert main(["gallery", "--only", "fig4", "fig7", "-o", str(tmp_path)]) == 0
    for name in ("fig4", "fig7"):
        img = Image.open(tmp_path / f"{name}.png").convert("RGB")
        assert img.size == (1400, 700)
        assert len(img.getcolors(1 << 20) or []) > 50        # a rendering, not a blank
    assert sorted(p.stem for p in tmp_path.glob("*.png")) == ["fig4", "fig7"]
    assert set(FIGURES) == {"fig1c", "fig1d", "fig4", "fig5", "fig6", "fig7", "fig8"}


def test_gallery_unknown_figure_is_a_usage_error(tmp_path, capsys):
    assert main(["gallery", "--only", "fig9", "-o", str(tmp_path)]) == 2
    assert "no figure fig9" in capsys.readouterr().err
