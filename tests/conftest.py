import os
import sys
import tempfile
from pathlib import Path

from hypothesis import settings

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

# Part-database caches go to one folder per session, never into the source tree.
os.environ.setdefault("CITYSYNTH_CACHE", tempfile.mkdtemp(prefix="citysynth-cache-"))

# CI runs a fixed set of examples so a landing never hinges on a lucky draw; locally
# every run explores new ones.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
