# Two commands: `make run` and `make test` (ruff lint and format check, then pytest). Each creates .venv on first use and
# reinstalls only when pyproject.toml changed (the stamp file tracks it).
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: run test bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,reference]'
	touch $(STAMP)

# The quick suite writes to out/quick (ignored by git), so running it never edits the
# committed results/; `bnerr bench --suite NAME` (default --out results/NAME) regenerates those.
run: $(STAMP)
	$(BIN)/bnerr bench --suite quick --out out/quick

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest -q

clean:
	rm -rf $(VENV) build *.egg-info
