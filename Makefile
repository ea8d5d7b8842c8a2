# enctools — make demo (fresh machine: venv, install, calibration campaigns) and make test.
PYTHON  ?= python3
VENV    := .venv
BIN     := $(VENV)/bin
OUT     ?= demo-out
ENC     := $(abspath $(BIN)/enc)
# the oldest versions pyproject.toml declares, in a venv of their own (make test-min)
VENV_MIN := .venv-min
MIN_PINS := tests/min-versions.txt
# two workers: the tests of a file that share a module's fixture (a simulator run) go to one
# worker together, every other test (the catalogue's cases too) is handed out on its own,
# the slow ones first (tests/conftest.py groups them), so both workers end together
PYTEST   = -m pytest -q -n 2 --dist loadgroup

.DEFAULT_GOAL := help
.PHONY: help install demo screenshot nightly chromium poppler test test-slow check test-min bench \
        durations \
        accuracy fuzz man \
        lint typecheck clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | sed 's/:.*## /\t/' | expand -t 12

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip

# the man pages are installed as copies (share/man of the venv): a changed page reinstalls
MAN_PAGES := $(wildcard man/*.[15])

# the optional compiled kernel is built by the install (hatch_build.py): a changed source rebuilds
KERNEL := enctools/_kernel.c hatch_build.py enctools/kernel_build.py

$(VENV)/.installed: pyproject.toml $(MAN_PAGES) $(KERNEL) | $(BIN)/python
	$(BIN)/python -m pip install -q -e .
	@touch $@

$(VENV)/.installed-test: $(VENV)/.installed
	$(BIN)/python -m pip install -q -e '.[test]'
	@touch $@

# with the hardware extras, so that mypy sees pyvisa's types
$(VENV)/.installed-lint: $(VENV)/.installed
	$(BIN)/python -m pip install -q -e '.[lint,hw]'
	@touch $@

# compiled packages as wheels only: a floor without a wheel for this Python fails at once
$(VENV_MIN)/.installed: pyproject.toml $(MIN_PINS) $(MAN_PAGES) $(KERNEL)
	rm -rf $(VENV_MIN)
	$(PYTHON) -m venv $(VENV_MIN)
	$(VENV_MIN)/bin/python -m pip install -q --only-binary numpy,scipy,pyarrow,h5py,matplotlib \
	    -c $(MIN_PINS) -e '.[test]'
	@touch $@

install: $(VENV)/.installed  ## create .venv and install enctools into it

demo: $(VENV)/.installed  ## run both papers' campaigns on the simulated rigs into demo-out/
	@mkdir -p $(OUT)
	$(MAKE) --no-print-directory -f examples/sjtu-dual.mk ENC=$(ENC) OUT=$(OUT)/sjtu-dual
	$(MAKE) --no-print-directory -f examples/ciomp-23bit.mk ENC=$(ENC) OUT=$(OUT)/ciomp-23bit
	@echo "demo: results in $(OUT)/"

screenshot: demo chromium  ## picture of the demo's HTML report for the README
	bin/enc-report-screenshot $(OUT)/sjtu-dual/report.html docs/report.png 1000 2400

nightly: $(VENV)/.installed  ## one nightly recheck of ciomp-23bit into nightly/ (exit 1 on drift)
	PATH=$(abspath $(BIN)):$$PATH bin/enc-nightly --rig ciomp-23bit --history nightly/history \
	    --calibration nightly/calibration.parquet --init --html nightly/latest.html --force

# Headless Chromium renders the HTML report in one test; installed when we may (root, apt).
chromium:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && (apt-get update -qq && apt-get install -y -qq chromium) >/dev/null 2>&1; } \
	  || echo "make: chromium is not installed; the report screenshot test will be skipped"

# pdfinfo and pdftotext (poppler-utils) read the PDF report in one test; installed when we may
poppler:
	@command -v pdfinfo >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && (apt-get update -qq && apt-get install -y -qq poppler-utils) >/dev/null 2>&1; } \
	  || echo "make: poppler-utils is not installed; the PDF report's poppler checks will be skipped"

# Three tiers, every test in one of them and every tier in CI (.ci/run): make check, the
# library's own tests (no command, nothing slow); make test, everything but the slow tier;
# make test-slow, the slow tier (the adversarial catalogue's hostile cases, the man pages'
# and README's examples, full-size simulator runs, many processes: `slow` in the tests).
test: $(VENV)/.installed-test chromium poppler  ## install what the tests need, run all but the slow tier
	$(BIN)/python $(PYTEST) -m 'not slow'

test-slow: $(VENV)/.installed-test chromium poppler  ## the slow tier (the catalogue, the examples...)
	$(BIN)/python $(PYTEST) -m slow

# make check's xdist workers: two, quiet or loaded, though each collects the suite again
# (1.8 s of CPU): the cores are shared per runnable process, and serial it took 101 s
# beside four spinning processes where two workers took 35 s (README, Development).
# 12-15 s on two cores at load average 3; 15-28 s beside one or two spinning processes
# per core at load average 6 (benchmarks/check_loaded.py; README)
CHECK_WORKERS ?= 2
check: $(VENV)/.installed-test  ## the fast tier: the library's quick tests, no command run (12-15 s; 22-28 s beside 2 busy processes a core)
	@$(BIN)/python -c "import os; print('load average (1, 5, 15 min): %.2f %.2f %.2f' % os.getloadavg())"
	@echo "workers: $(CHECK_WORKERS)"
	$(BIN)/python -m pytest -q -n $(CHECK_WORKERS) --dist loadgroup \
	    -m 'not slow and not command and not heavy' --durations=5

# both tiers in one run: the oldest versions have failed in the slow tier's cases alone (pyarrow
# 14 started a thread that hung every forked catalogue command; a signal during enc-nightly's
# imports gave a traceback), so test-min does not keep to the fast tier
test-min: $(VENV_MIN)/.installed  ## the whole suite, both tiers, on the oldest declared versions (.venv-min)
	$(VENV_MIN)/bin/python $(PYTEST)

# every test's wall and CPU seconds (tests/conftest.py, ENCTOOLS_TEST_TIMES), both tiers in turn
durations: $(VENV)/.installed-test chromium poppler  ## the 25 slowest tests of make test and make test-slow (README)
	@rm -f durations.jsonl
	@$(BIN)/python -c "import os; print('load average (1, 5, 15 min): %.2f %.2f %.2f' % os.getloadavg())"
	ENCTOOLS_TEST_TIMES=$(CURDIR)/durations.jsonl $(BIN)/python $(PYTEST) -m 'not slow'
	ENCTOOLS_TEST_TIMES=$(CURDIR)/durations.jsonl $(BIN)/python $(PYTEST) -m slow
	$(BIN)/python benchmarks/slowest_tests.py durations.jsonl --top 25

bench: $(VENV)/.installed  ## measure speed and memory of every command (table for the README)
	$(BIN)/python benchmarks/bench.py --out bench-out
	$(BIN)/python benchmarks/rom_writer.py command --out bench-out
	$(BIN)/python benchmarks/fleet.py --out bench-out
	$(BIN)/python benchmarks/interp_fit.py --revolutions 300,2000 --out bench-out
	$(BIN)/python benchmarks/acquire_steps.py --out bench-out
	$(BIN)/python benchmarks/fit_rbf.py --signal --out bench-out
	$(BIN)/python benchmarks/budget_mc.py --runs 2000
	$(BIN)/python benchmarks/comparison_mc.py --runs 4000
	$(BIN)/python benchmarks/steprun_mc.py --runs 4000
	$(BIN)/python benchmarks/polygon_runs_mc.py --runs 2000
	$(BIN)/python benchmarks/polygon_gum_mc.py --draws 200000
	$(BIN)/python benchmarks/selfcal_mc.py --runs 2000
	$(BIN)/python benchmarks/interp_mc.py --runs 4000
	$(BIN)/python benchmarks/correction_u_mc.py --trials 30

SEEDS ?= 20
accuracy: $(VENV)/.installed  ## the README's accuracy table over SEEDS noise seeds (minutes)
	$(BIN)/python benchmarks/accuracy.py --seeds $(SEEDS)

FUZZ_SECONDS ?= 300
# three fuzzers, a third of FUZZ_SECONDS each: streams, rig files, CSV and correction tables
fuzz: $(VENV)/.installed  ## fuzz stream readers, rig files and tables with atheris (findings in fuzz-out/)
	$(BIN)/python -m pip install -q atheris
	@mkdir -p fuzz-out
	$(BIN)/python tests/fuzz_readers.py fuzz-out/corpus -max_total_time=$$(($(FUZZ_SECONDS) / 3)) \
	    -artifact_prefix=fuzz-out/ -rss_limit_mb=4096
	$(BIN)/python tests/fuzz_rigs.py fuzz-out/corpus-rigs -max_total_time=$$(($(FUZZ_SECONDS) / 3)) \
	    -artifact_prefix=fuzz-out/rigs- -rss_limit_mb=4096
	$(BIN)/python tests/fuzz_tables.py fuzz-out/corpus-tables \
	    -max_total_time=$$(($(FUZZ_SECONDS) / 3)) -artifact_prefix=fuzz-out/tables- -rss_limit_mb=4096

man:  ## check that every man page renders without warnings
	@for f in man/*.[15]; do out=$$(LC_ALL=C.UTF-8 MANWIDTH=80 man --warnings -l $$f 2>&1 >/dev/null); \
	  if [ -n "$$out" ]; then echo "$$f: $$out"; exit 1; fi; done; echo "man pages: ok"

# ruff check only: the code is laid out by hand (aligned continuation lines), not by ruff format
lint: $(VENV)/.installed-lint  ## ruff (pinned; rules in pyproject.toml) over the code and tests
	$(BIN)/ruff check enctools tests

typecheck: $(VENV)/.installed-lint  ## mypy (pinned; settings in pyproject.toml) over enctools
	$(BIN)/mypy

clean:  ## remove outputs (keeps .venv)
	rm -rf $(OUT) bench-out fuzz-out nightly durations.jsonl .pytest_cache .mypy_cache .ruff_cache
