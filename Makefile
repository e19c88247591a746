# Two commands on a fresh machine: `make demo` and `make test`. Both create .venv
# when it is missing and install the project (editable) with its test extras.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test lint bench examples library clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/citysynth demo

lint: $(STAMP)
	$(BIN)/ruff check .

test: lint
	$(BIN)/python -m pytest

bench: $(STAMP)
	$(BIN)/python -m bench.street
	$(BIN)/python -m bench.structures
	$(BIN)/python -m bench.export
	$(BIN)/python -m bench.ingest
	$(BIN)/python -m bench.city

examples: $(STAMP)
	$(BIN)/python -m examples.make_examples

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache .hypothesis
	find . -name __pycache__ -prune -exec rm -rf {} +

# The sample part library: regenerate the meshes and manifest, then the contact sheet.
library: $(STAMP)
	$(BIN)/python -m parts_db.sample
	$(BIN)/python -m export.preview examples/library docs/library.png
