# yore: `make test` and `make demo` do the whole set-up (Debian packages, .venv, the package)
# and are incremental: the CMake build folder build/ is kept between runs.

PYTHON ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
OUT ?= yore-out
# Everything the installed package is built from; a change re-runs the (incremental) install.
SOURCES := $(shell find cpp python cmake tests/cpp -type f -not -name '*.pyc' -not -path '*/__pycache__/*' 2>/dev/null) \
           CMakeLists.txt pyproject.toml

.PHONY: test-valgrind setup system test test-cpp test-fast docs lock demo bench bench-quick clean

setup: system $(VENV)/.installed

system:
	@PYTHON=$(PYTHON) bash tools/install_system_deps.sh

$(VPY):
	$(PYTHON) -m venv $(VENV)

# Build requirements live in the venv: the install below runs without build isolation so that
# scikit-build-core reuses the persistent CMake folder. Every Python package comes in at the
# version of the lock file constraints.txt (the versions `make test` passed with); requirements.in
# holds the open ranges, and `make lock` resolves them anew into constraints.txt, on purpose.
LOCK := constraints.txt
$(VENV)/.deps: $(VPY) requirements.in $(LOCK)
	$(VPY) -m pip install --quiet --upgrade pip -c $(LOCK)
	$(VPY) -m pip install --quiet -r requirements.in -c $(LOCK)
	@touch $@

# The C++ core is compiled once: the package's CMake folder (build/core) also builds the C++
# tests (YORE_BUILD_TESTS=ON here; a plain `pip install .` leaves them out), and `make test-cpp`
# runs them from there.
CORE_BUILD := build/core
$(VENV)/.installed: $(VENV)/.deps $(SOURCES)
	$(VPY) -m pip install --no-build-isolation --no-deps \
	    --config-settings=cmake.define.YORE_BUILD_TESTS=ON ".[test]"
	@touch $@

# The C++ tests and the docs run first, so that pytest's summary is the closing line. pytest
# runs on every core the process may use (pytest-xdist, -n auto): ~2x faster on two cores, one
# worker on one.
test: setup
	$(MAKE) --no-print-directory test-cpp
	$(MAKE) --no-print-directory docs
	$(VPY) -m pytest -q -n auto tests

# The C++ tests (doctest, tests/cpp: one file per source unit, one ctest test per file), built
# with the package in build/core (above) and run incrementally. CMAKE_BUILD_PARALLEL_LEVEL, when
# set, is ctest's parallel level too.
CPP_PARALLEL := $(if $(CMAKE_BUILD_PARALLEL_LEVEL),--parallel $(CMAKE_BUILD_PARALLEL_LEVEL))
test-cpp: setup
	ctest --test-dir $(CORE_BUILD) --output-on-failure $(CPP_PARALLEL)

# The C++ tests under valgrind's memcheck (reads of uninitialised memory, invalid accesses),
# after a change to the core's memory handling (issue 53: a TR-BDF2 history held heap garbage).
# Not part of `make test`: valgrind (Debian's package) takes ~25 s here. It emulates a CPU
# without AVX-512, so the test comparing CPUID with /proc/cpuinfo is left out.
test-valgrind: test-cpp
	@command -v valgrind >/dev/null || { echo "make test-valgrind needs valgrind (apt-get install valgrind)"; exit 2; }
	valgrind --error-exitcode=9 --track-origins=yes -q $(CORE_BUILD)/tests/cpp/yore_tests \
	    -tce="cpu_features agrees with the Linux kernel*"

# The tests a developer runs while editing: all but those marked slow (under a minute here).
test-fast: setup
	$(VPY) -m pytest -q -n auto -m "not slow" tests

# The documentation site (Sphinx: furo, MyST, autodoc, sphinx-gallery), warnings as errors:
# docs/_build/html/index.html.
docs: setup
	$(VPY) -m sphinx -W --keep-going -q -b html docs docs/_build/html

demo: setup
	$(VENV)/bin/yore demo -o $(OUT)

# Benchmarks pin BLAS to one thread: CHOLMOD and the dense reference then compete on equal terms.
BENCHMARKS := explicit_step implicit_step factorization rebuild_cost crossover long_horizon numerical_damping \
              error_control vibration_floor wrinkles interpolation_bending bending_consistency \
              sensitivity scaling newton_projection factor_reuse newton_stop newton_predictor \
              stability_map stable_dt \
              threads pictures
BENCH_ENV := OPENBLAS_NUM_THREADS=1

bench: setup
	@for name in $(BENCHMARKS); do \
	    echo "== $$name"; $(BENCH_ENV) $(VPY) -m benchmarks.$$name --out bench-results || exit 1; \
	done
	$(VPY) -m benchmarks.report --results bench-results --page docs/results.md

bench-quick: setup
	@for name in $(BENCHMARKS); do \
	    echo "== $$name"; $(BENCH_ENV) $(VPY) -m benchmarks.$$name --quick --out bench-results \
	        || exit 1; \
	done

# The lock file: the newest versions requirements.in allows, resolved in a fresh venv (under the
# build folder), written atomically. Run it on purpose, then `make test`, then commit the file.
LOCK_VENV := build/lock-venv
lock:
	rm -rf $(LOCK_VENV)
	$(PYTHON) -m venv $(LOCK_VENV)
	$(LOCK_VENV)/bin/python -m pip install --quiet --upgrade pip
	$(LOCK_VENV)/bin/python -m pip install --quiet -r requirements.in
	{ echo "# yore's lock file: the versions \`make setup\` installs (pip constraints), written by"; \
	  echo "# \`make lock\` from requirements.in with $$($(LOCK_VENV)/bin/python -V) on $$(date -u +%Y-%m-%d)."; \
	  $(LOCK_VENV)/bin/python -m pip freeze --all; } > $(LOCK).tmp
	mv $(LOCK).tmp $(LOCK)
	rm -rf $(LOCK_VENV)
	@echo "wrote $(LOCK); run make test before committing it"

clean:
	rm -rf build $(VENV) $(OUT) bench-results
