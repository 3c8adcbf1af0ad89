# Two commands on a fresh machine: `make run` and `make test`.
# `make test-min` runs the suite again on the lowest versions pyproject.toml claims, less the
# tests marked `slow` (end-to-end tests whose dependency calls the other tests make too).
PYTHON   ?= python3
VENV     := .venv
BIN      := $(VENV)/bin
STAMP    := $(VENV)/.installed
OUT      ?= out/loop
MIN_VENV := .venv-min
MIN_PINS := .ci/min-versions.txt

.PHONY: run test test-min chromium bench clean

$(STAMP): pyproject.toml setup.py $(wildcard rcsim/*/_*.c)
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,lint]'
	touch $(STAMP)

# The analyst's loop on defaults (campaign -> drivers -> refined table -> report).  A second
# `make run` resumes the loop in $(OUT) (finishing a stopped one, or just naming its report).
run: $(STAMP)
	$(BIN)/rcsim loop --out $(OUT) $$(test -f $(OUT)/loop.json && echo --resume)

# Lint, format and types first (seconds), then the suite.
test: $(STAMP) chromium
	$(BIN)/ruff check --quiet .
	$(BIN)/ruff format --check --quiet .
	$(BIN)/mypy
	$(BIN)/python -m pytest -q

# The HTML report is tested in headless Chromium (Debian package `chromium`), and its printed
# PDF read back with poppler's `pdftotext` (Debian package `poppler-utils`).  Install them when
# one is missing and this user can (root with apt-get); otherwise say so and carry on: the
# browser tests then skip and name the reason, so a machine without apt never fails the build.
chromium:
	@if command -v chromium >/dev/null 2>&1 && command -v pdftotext >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	  echo "chromium: installing the Debian packages chromium and poppler-utils with apt-get (can take a minute)"; \
	  log=$$(mktemp); \
	  if { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium poppler-utils; } \
	      >"$$log" 2>&1; then :; \
	  else tail -n 3 "$$log"; echo "chromium: apt-get install failed; browser tests will skip"; fi; \
	  rm -f "$$log"; \
	else \
	  echo "chromium: chromium or pdftotext not installed (no apt-get, or not root); browser tests will skip"; \
	fi

# Lowest versions: a separate venv with exactly the pins of $(MIN_PINS), rcsim built as a wheel
# (not editable) so that a package or data file missing from pyproject.toml fails here too.
# Built from scratch every time: a venv left over from other pins would prove nothing.
# `-m "not slow"`: the slow end-to-end tests fly code the other tests fly too, so on these pins
# they would only repeat calls already made (docs/dependencies.md); `make test` runs them.
test-min:
	rm -rf $(MIN_VENV) build
	$(PYTHON) -m venv $(MIN_VENV)
	$(MIN_VENV)/bin/python -m pip install --quiet -c $(MIN_PINS) setuptools
	$(MIN_VENV)/bin/python -m pip install --quiet --no-build-isolation -c $(MIN_PINS) '.[test]'
	rm -rf build
	$(MIN_VENV)/bin/python -m pip list --format=freeze >$(MIN_VENV)/versions.txt
	$(MIN_VENV)/bin/python -m pytest -q -p no:cacheprovider -m "not slow"

bench: $(STAMP)
	$(BIN)/python benchmarks/maneuver.py

clean:
	rm -rf $(VENV) $(MIN_VENV) out build *.egg-info
