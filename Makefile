# yore: `make test` and `make demo` do the whole set-up (Debian packages, .venv, the package)
# and are incremental: the CMake build folder build/ is kept between runs.

PYTHON ?= python3
VENV := .venv
VPY := $(VENV)/bin/python
OUT ?= yore-out
# Everything the installed package is built from; a change re-runs the (incremental) install.
SOURCES := $(shell find cpp python cmake -type f -not -name '*.pyc' -not -path '*/__pycache__/*' 2>/dev/null) \
           CMakeLists.txt pyproject.toml

.PHONY: setup system test demo bench bench-quick clean

setup: system $(VENV)/.installed

system:
	@PYTHON=$(PYTHON) bash tools/install_system_deps.sh

$(VPY):
	$(PYTHON) -m venv $(VENV)

# Build requirements live in the venv: the install below runs without build isolation so that
# scikit-build-core reuses the persistent CMake folder.
$(VENV)/.deps: $(VPY) pyproject.toml
	$(VPY) -m pip install --quiet --upgrade pip
	$(VPY) -m pip install --quiet "scikit-build-core>=0.10" "pybind11>=2.13" "numpy>=1.23" \
	    "meshio>=5.3,<6" "tqdm>=4.60" "pillow>=9" "pytest>=7" "hypothesis>=6" "matplotlib>=3.6" \
	    "polyscope>=2.6,<2.7" "dask[distributed]>=2024.1" "xarray>=2024.1" "h5netcdf>=1.3" "h5py>=3.8"
	@touch $@

$(VENV)/.installed: $(VENV)/.deps $(SOURCES)
	$(VPY) -m pip install --no-build-isolation --no-deps ".[test]"
	@touch $@

test: setup
	$(VPY) -m pytest -q tests

demo: setup
	$(VENV)/bin/yore demo -o $(OUT)

# Benchmarks pin BLAS to one thread: CHOLMOD and the dense reference then compete on equal terms.
BENCHMARKS := explicit_step implicit_step rebuild_cost crossover scaling newton_projection factor_reuse \
              stability_map stable_dt threads pictures
BENCH_ENV := OPENBLAS_NUM_THREADS=1

bench: setup
	@for name in $(BENCHMARKS); do \
	    echo "== $$name"; $(BENCH_ENV) $(VPY) -m benchmarks.$$name --out bench-results || exit 1; \
	done
	$(VPY) -m benchmarks.report --results bench-results --readme README.md

bench-quick: setup
	@for name in $(BENCHMARKS); do \
	    echo "== $$name"; $(BENCH_ENV) $(VPY) -m benchmarks.$$name --quick --out bench-results \
	        || exit 1; \
	done

clean:
	rm -rf build $(VENV) $(OUT) bench-results
