"""The files citysynth ships to run with no user data: the sample part library and the
demo inputs. Installed as package data (``citysynth.examples``), so ``citysynth demo``
works from a wheel in any folder.

>>> from citysynth.examples import SAMPLE_LIBRARY
>>> (SAMPLE_LIBRARY / "manifest.toml").is_file()
True
"""

from pathlib import Path

ROOT = Path(__file__).resolve().parent
SAMPLE_LIBRARY = ROOT / "library"
CITY = ROOT / "city"

__all__ = ["CITY", "ROOT", "SAMPLE_LIBRARY"]
