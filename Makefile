# labkit — two commands for people (`make lab`, `make test`), a few more for developers.
# The virtual environment is created on first use; every later target reuses it.

PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
LAB_ARGS ?=
PYTEST_ARGS ?=
# Test workers (pytest-xdist): one per core. Whole files go to one worker (--dist loadfile),
# so a notebook's cells run in order in one kernel and the browser test starts one JupyterLab.
TEST_JOBS ?= $(shell nproc 2>/dev/null || echo 2)
XDIST := -n $(TEST_JOBS) --dist loadfile

.PHONY: lab test test-fast bench firmware firmware-all clean browser-deps student sheets book

$(STAMP): pyproject.toml constraints.txt
	@$(PYTHON) -c 'import sys; assert sys.version_info >= (3, 11), "labkit needs Python >= 3.11, found " + sys.version.split()[0]'
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[lab,test]'
	touch $(STAMP)

## make lab: set up (first time) and open JupyterLab on the index notebook.
ROOT_ARGS := $(if $(filter 0,$(shell id -u 2>/dev/null)),--allow-root,)
lab: $(STAMP)
	@echo "labkit: compiling every kernel the chapters and commands use, once for this install (minutes the first time, then seconds)"
	@$(PY) -m labkit._jit warm || echo "note: some kernels will compile when first used"
	$(VENV)/bin/jupyter lab --ServerApp.root_dir="$(CURDIR)" \
		--LabApp.default_url=/lab/tree/notebooks/00-index.ipynb $(ROOT_ARGS) $(LAB_ARGS)

## make test: set up (first time), the firmware's host tests (C), then unit tests, doctests,
## notebooks (nbval) and the browser test.
test: $(STAMP) browser-deps
	$(MAKE) -C firmware test sim
	$(PY) -m pytest $(XDIST) $(PYTEST_ARGS)

## make student STUDENT_DIR=DIR: the student edition of every chapter (answers replaced by stubs,
## the appendices for researchers removed, the other outputs kept).
STUDENT_DIR ?= student
student: $(STAMP)
	$(PY) -m labkit course student "$(STUDENT_DIR)"

## make sheets SHEETS_DIR=DIR: the printable material (HTML): exercise sheet, answer key, a handout
## per lesson, the marking scheme, the capstone rubric (default build/sheets).
SHEETS_DIR ?= build/sheets
sheets: $(STAMP)
	$(PY) tools/course_sheets.py "$(SHEETS_DIR)"

## make book BOOK_DIR=DIR: the course as a website from the student edition (MkDocs + mkdocs-jupyter,
## offline); open DIR/site/index.html (default build/book).
BOOK_DIR ?= build/book
book: $(STAMP)
	$(PY) -m pip install --quiet -c constraints.txt -e '.[book]'
	$(PY) tools/course_book.py "$(BOOK_DIR)"

## make firmware-all: what CI adds to make test: the ARM images (sizes printed), the job
## streamed to the image in QEMU, and a bounded libFuzzer run (FUZZ_SECONDS per target).
firmware-all:
	$(MAKE) -C firmware arm qemu fuzz

## make test-fast: everything but the notebooks and the browser.
test-fast: $(STAMP)
	$(PY) -m pytest -o addopts="--doctest-modules --strict-markers -p no:cacheprovider" -m "not browser" $(XDIST) tests labkit $(PYTEST_ARGS)

## make bench: install the peer libraries and run every benchmark, printing ratios.
bench: $(STAMP)
	$(PY) -m pip install --quiet -c constraints.txt -e '.[bench]'
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

## The browser test needs Debian's chromium and chromedriver; install them when we can.
browser-deps:
	@if [ -x /usr/bin/chromium ] && [ -x /usr/bin/chromedriver ]; then :; \
	elif command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
		echo "installing chromium and chromium-driver (apt) for the browser test"; \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null \
		|| (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null); \
	else \
		echo "note: chromium/chromedriver missing and no root apt-get; see environment.md (browser test will be skipped unless LABKIT_REQUIRE_BROWSER=1)"; \
	fi

clean:
	rm -rf build .pytest_cache
	find . -name __pycache__ -prune -exec rm -rf {} +
