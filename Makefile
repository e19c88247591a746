# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv
# when it is missing and install the project (editable) with its test extras.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test test-deep lint typecheck bench examples library clean wheel

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --no-cache-dir --upgrade pip
	$(BIN)/python -m pip install --quiet --no-cache-dir -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/citysynth demo

lint: $(STAMP)
	$(BIN)/ruff check .
	$(MAKE) --no-print-directory typecheck

# mypy on the installed layout: a tree of links named citysynth/ under build/
typecheck: $(STAMP)
	mkdir -p build/typecheck/citysynth
	for d in pipeline parts_db skeletons solver export examples; do \
		ln -sfn ../../../$$d build/typecheck/citysynth/$$d; done
	cd build/typecheck && ../../$(BIN)/mypy --config-file ../../pyproject.toml -p citysynth

# Khronos's glTF Validator (npm), which tests/test_gltf.py runs on every GLB it checks
GLTF_VALIDATOR := build/node/node_modules/gltf-validator/package.json
$(GLTF_VALIDATOR):
	mkdir -p build/node
	npm install --prefix build/node --no-audit --no-fund --silent gltf-validator@2.0.0-dev.3.10

# Blender as a Python module (tests/test_blender.py imports our USD and GLB with it): its
# own venv, since bpy carries its own USD and wants numpy 1.x; the wheel is 0.5 GB
BPY_STAMP := build/bpy/.installed-stamp
$(BPY_STAMP): | $(STAMP)
	$(BIN)/python -m venv --clear build/bpy
	build/bpy/bin/python -m pip install --quiet --no-cache-dir "bpy==4.2.0" "numpy<2"
	touch $(BPY_STAMP)

# Hypothesis draws a fixed set of examples per test (profile "default"); test-deep draws
# new ones every run, eight times as many, with no deadline (tests/conftest.py).
test: lint $(GLTF_VALIDATOR) $(BPY_STAMP)
	$(BIN)/python -m pytest

test-deep: lint $(GLTF_VALIDATOR) $(BPY_STAMP)
	HYPOTHESIS_PROFILE=deep $(BIN)/python -m pytest

bench: $(STAMP)
	$(BIN)/python -m bench.street
	$(BIN)/python -m bench.structures
	$(BIN)/python -m bench.export
	$(BIN)/python -m bench.ingest
	$(BIN)/python -m bench.city

examples: $(STAMP)
	$(BIN)/python -m examples.make_examples

clean:
	rm -rf $(VENV) out build dist .pytest_cache .ruff_cache .hypothesis .mypy_cache
	find . -name __pycache__ -prune -exec rm -rf {} +

# The sample part library: regenerate the meshes and manifest, then the contact sheet.
library: $(STAMP)
	$(BIN)/python -m citysynth.parts_db.sample
	$(BIN)/python -m citysynth.export.preview examples/library docs/library.png
