"""The names of the files a city run writes into its folder.

A module of its own, with nothing to import, so what reads a run folder
(``citysynth diff``) need not load what writes one.
"""

BLOCKS_DIR = "blocks"              # a block's layout JSON, USD and cuts: blocks/<id>*
MANIFEST = "manifest.json"         # every block's inputs hash, status, files and cost
BLOCKS_GEOJSON = "blocks.geojson"  # every block's outline with its status, for a GIS
REPORT = "report.json"             # counts, timings, failures and errors of the run
RUN_SCHEMA = "citysynth.run"       # the manifest's "schema"
