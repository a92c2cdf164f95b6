# Two commands: `make run` and `make test` (ruff lint and format check, mypy on bnerr/,
# renderers/, denoisers/ and benchmarks/ as configured in pyproject.toml, then pytest over every
# core with pytest-xdist). Each creates .venv on first use and reinstalls only when pyproject.toml
# changed (the stamp file tracks it). The install goes through uv (itself a wheel from PyPI): it
# fetches and unpacks in parallel and keeps a cache, measured 91 s for a cold install against
# pip's 140 s here; pip takes over if uv cannot be installed. The extras: dev (pytest,
# pytest-xdist, hypothesis, ruff, mypy), reference (Mitsuba 3, OIDN, FLIP) and cluster (Ray).
# Mitsuba's LLVM variants need libLLVM >= 19: where make runs as root on Debian it installs
# libllvm19 (best effort; without it the tests that need it skip and say why). Likewise the
# browser tests of the results pages (tests/benchmarks/reports/test_page.py) drive Debian's chromium through
# Playwright; `make chromium` installs it as root on Debian, elsewhere those tests skip. The Cycles
# back-end (renderers/cycles) needs bpy, Blender as a Python module, which pins numpy<2 while bnerr
# needs numpy 2: `make cycles` gives it a venv of its own, .venv-cycles (bpy 4.5.4 LTS, Python
# 3.11; about 1.1 GB, a minute from a cold cache), which bnerr starts as a separate process. Where
# no wheel installs, the Cycles tests skip and say why.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
BPY    := bpy==4.5.4
CYCLES := .venv-cycles
CYCLES_STAMP := $(CYCLES)/.installed-$(BPY)

.PHONY: run test bench clean llvm chromium cycles

llvm:
	@if ldconfig -p 2>/dev/null | grep -q 'libLLVM.so.19\|libLLVM-19'; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  (apt-get install -y -qq libllvm19 >/dev/null 2>&1 || \
	   (apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq libllvm19 >/dev/null 2>&1)) || \
	  echo "note: libllvm19 not installed; tests of Mitsuba's LLVM variants will skip"; \
	else echo "note: no libLLVM 19 (Debian: apt-get install libllvm19); tests of Mitsuba's LLVM variants will skip"; fi

chromium:
	@if [ -x /usr/bin/chromium ]; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  (apt-get install -y -qq chromium >/dev/null 2>&1 || \
	   (apt-get update -qq >/dev/null 2>&1 && apt-get install -y -qq chromium >/dev/null 2>&1)) || \
	  echo "note: chromium not installed; the browser tests of the results pages will skip"; \
	else echo "note: no /usr/bin/chromium (Debian: apt-get install chromium); the browser tests will skip"; fi

cycles: $(CYCLES_STAMP)

$(CYCLES_STAMP): | $(STAMP)
	@rm -f $(CYCLES)/.installed-*
	@if ($(PYTHON) -m venv $(CYCLES) >/dev/null 2>&1 || python3 -m venv $(CYCLES) >/dev/null 2>&1) && \
	  ($(BIN)/uv pip install --quiet --python $(CYCLES)/bin/python '$(BPY)' 2>/dev/null || \
	   $(CYCLES)/bin/python -m pip install --quiet '$(BPY)' 2>/dev/null); then touch $@; \
	else echo "note: $(BPY) not installed in $(CYCLES); the Cycles tests will skip"; fi

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	if $(BIN)/python -m pip install --quiet uv; then \
	  $(BIN)/uv pip install --quiet --python $(BIN)/python -e '.[dev,reference,cluster]'; \
	else $(BIN)/python -m pip install --quiet -e '.[dev,reference,cluster]'; fi
	@$(MAKE) --no-print-directory llvm
	@$(MAKE) --no-print-directory chromium
	touch $(STAMP)

# The quick suite writes to out/quick (ignored by git), so running it never edits the
# committed results/; `bnerr bench --suite NAME` (default --out results/NAME) regenerates those.
run: $(STAMP) cycles
	$(BIN)/bnerr bench --suite quick --out out/quick

# mypy (30 s on one core from a cold cache) runs beside pytest, its report printed after it: on
# the 2-core machine it takes the core that pytest's last file leaves idle. Either failing fails.
test: $(STAMP) cycles
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	@$(BIN)/mypy > $(VENV)/mypy.log 2>&1 & mypy=$$!; \
	$(BIN)/python -m pytest -q -n auto --dist loadfile --no-loadscope-reorder; tests=$$?; \
	wait $$mypy; typed=$$?; echo "mypy:"; cat $(VENV)/mypy.log; \
	test $$tests = 0 && test $$typed = 0

clean:
	rm -rf $(VENV) $(CYCLES) build *.egg-info
