# chainsweep — one entry point for building, testing, benchmarking and the paper's figures.
#
#   make test      builds everything (installing what it needs into .venv) and runs every test
#   make figures   runs the paper's sweeps on a small default and draws the figures into results/
#   make bench     benchmarks, before (BENCH_BASE, default main) and after side by side: right-hand-
#                  side cost per contact, the reference run, each contact law and model; then the
#                  default, no-FMA and native builds side by side (scripts/bench_builds.sh); the
#                  results store on a 20 000-run history sweep, a 100 000-run summary sweep and
#                  a 2 511-run sweep of 1 ms histories, before and after (scripts/bench_store.py:
#                  bytes written, peak memory, files, write and read throughput, bytes per run); and
#                  the reference run against a physicist's scipy script of the same chain at the
#                  same accuracy (scripts/bench_scipy.py); the Fig. 8 sweep against numba +
#                  numbalsoda LSODA, both ladders of error against time (scripts/bench_numba_lsoda.py)
#   make examples  runs the example chains of sweeps/examples/ and draws them into results/examples/
#   make python    the Python package (python/) built by maturin and installed into .venv
#   make wheel     the Python package as a wheel for other machines (clusters): dist/chainsweep-*.whl,
#                  abi3 (CPython >= 3.10), manylinux (glibc >= WHEEL_GLIBC), stripped; it installs
#                  `import chainsweep` and the `chainsweep` command, with the example sweeps, the
#                  guides and the licences. No Rust toolchain is needed where it is installed.
#
# The HDF5 library is built from source (hdf5-metno's `static` feature) and needs CMake >= 3.26;
# when the machine has none or an older one, CMake comes from PyPI into .venv.

SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
CMAKE_MIN := 3.26
CARGO ?= cargo

export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)
# pyo3 (python/) reads its build configuration (CPython, stable ABI >= 3.10) from this one file in
# every cargo command here and in maturin's: without it, each would rebuild pyo3 after the other.
export PYO3_CONFIG_FILE := $(CURDIR)/python/pyo3-config.txt

.PHONY: all build bin test test-system test-rust test-python python wheel ncdump bench figures examples fmt lint lint-all venv clean

all: build

$(VENV)/.stamp: requirements.txt
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	$(VENV)/bin/pip install --quiet -r requirements.txt
	@if ! command -v cmake >/dev/null 2>&1 || \
	   ! printf '%s\n%s\n' "$(CMAKE_MIN)" "$$(cmake --version | head -1 | awk '{print $$3}')" | sort -V -C; then \
	  echo "installing CMake >= $(CMAKE_MIN) from PyPI into $(VENV)"; \
	  $(VENV)/bin/pip install --quiet 'cmake>=$(CMAKE_MIN),<4'; \
	fi
	touch $@

venv: $(VENV)/.stamp

build: venv
	$(CARGO) build --release --workspace

# The command-line binary alone (what the Python tests run; `make test-rust` has built it already).
# --workspace, not -p chainsweep: the features of the dependencies are then resolved over the whole
# workspace, as in every other cargo command here (pyo3's syn features among them), so nothing is
# compiled again.
bin: venv
	$(CARGO) build --release --workspace --bins

fmt:
	$(CARGO) fmt --all

# Every cargo step uses the release profile: the HDF5 C library is then compiled once (minutes on
# two cores), not once per profile, and the physics tests run at full speed.
# `make lint` checks the units the tests build (the libraries, their tests, the binary);
# `make lint-all` (in `make test-system`) everything else too: the examples, and the benches with
# the solver's `bench` feature (criterion), which `make test` never compiles.
lint: venv
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --workspace --tests --bins -- -D warnings

# `make test` lints while it builds: clippy's driver compiles the workspace's own crates (cargo's
# RUSTC_WORKSPACE_WRAPPER; the dependencies are compiled by rustc as always) for the tests, the
# binary and the Python extension, with clippy's lints at -D warnings (CLIPPY_ARGS, as
# `cargo clippy -- -D warnings` passes them). The same units as `make lint`'s and the extension's
# too, without a second pass over every dependency for clippy's metadata. Cargo keeps these
# artefacts apart from a plain build's, so `make bin` or `make figures` afterwards compile the
# workspace's crates once more, not the dependencies. The driver is called through
# scripts/lint_and_compile.sh, which compiles the workspace's crates with 16 codegen units (a third
# less wall on two cores, the same numbers bit for bit; see there). lint-canary fails if the driver
# ever stopped linting: a `&Vec` argument (clippy::ptr_arg) must be refused.
CLIPPY_DRIVER := $(shell rustup which clippy-driver 2>/dev/null || command -v clippy-driver)
CLIPPY_DENY := -D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__
test: export CHAINSWEEP_CLIPPY_DRIVER := $(CLIPPY_DRIVER)
test: export RUSTC_WORKSPACE_WRAPPER := $(CURDIR)/scripts/lint_and_compile.sh
test: export CLIPPY_ARGS := $(CLIPPY_DENY)

.PHONY: fmt-check lint-canary
fmt-check:
	$(CARGO) fmt --all -- --check

lint-canary:
	@test -n "$(CLIPPY_DRIVER)" || { echo "clippy-driver not found: rustup component add clippy"; exit 1; }
	@dir=$$(mktemp -d); printf 'pub fn canary(x: &Vec<f64>) -> usize {\n    x.len()\n}\n' > $$dir/canary.rs; \
	if CLIPPY_ARGS="$(CLIPPY_DENY)" CHAINSWEEP_CLIPPY_DRIVER=$(CLIPPY_DRIVER) \
	     scripts/lint_and_compile.sh rustc --edition 2021 --crate-type lib \
	     --out-dir $$dir $$dir/canary.rs > $$dir/out 2>&1 || ! grep -q 'clippy::ptr_arg' $$dir/out; then \
	  rm -rf $$dir; echo "clippy's driver did not refuse a lint: make test would not lint"; exit 1; fi; \
	rm -rf $$dir

lint-all: venv
	$(CARGO) clippy --release --workspace --all-targets --all-features -- -D warnings

# The unit tests, the integration tests (one binary per crate, see crates/*/tests/suite.rs) and the
# doc tests. Not the examples, which `cargo test` would otherwise compile and link with the release
# profile only to check that they build: `make lint` checks them, and `make bench` builds those it
# runs.
test-rust: venv
	$(CARGO) test --release --workspace --tests
	$(CARGO) test --release --workspace --doc

# The Python package (python/): maturin builds it in the workspace's target directory, so the
# HDF5 library and the runner are compiled once for the binary and the package (after `bin`, not
# `build`: maturin compiles the extension itself, so building it in `build` first only doubled
# pyo3 and the extension's crate, about 35 s on two cores), and pip installs
# it into .venv (offline: maturin comes from requirements.txt; see PYO3_CONFIG_FILE above).
python: bin
	$(PY) scripts/package_files.py --cargo $(CARGO)
	$(PY) -m pip install --quiet --no-build-isolation --no-deps ./python

# The wheel for other machines (python/pyproject.toml; tests/test_wheel.py installs it into a
# clean venv). zig (PyPI's ziglang) compiles and links everything, the HDF5 and zlib C sources
# included, against glibc WHEEL_GLIBC's symbols: the wheel is tagged manylinux_<WHEEL_GLIBC>, which
# `auditwheel show` confirms. Cargo profile `wheel`: the release build's optimisation, stripped and
# without the release profile's debug info. The package's copies of the example sweeps, the guides
# and the C libraries' licence notices come from scripts/package_files.py. The build has its own
# artefacts (target/x86_64-unknown-linux-gnu/wheel/): about 3 minutes on two cores from clean.
WHEEL_DIR := dist
WHEEL_GLIBC ?= 2_17
$(VENV)/.wheel-stamp: requirements-wheel.txt $(VENV)/.stamp
	$(VENV)/bin/pip install --quiet -r requirements-wheel.txt
	touch $@

# -fno-sanitize=undefined for the wheel's C code: zig's cc turns UBSan on where no optimisation level
# is given, as in the checks of zlib-ng's and HDF5's CMake configure, and builds its UBSan runtime for
# each CPU-feature set those checks try (13 for zlib-ng, about two minutes on two cores while zig's
# cache is cold). The library's own objects are compiled optimised, without UBSan either way.
WHEEL_CFLAGS := $(CFLAGS) -fno-sanitize=undefined
wheel: venv $(VENV)/.wheel-stamp
	$(PY) scripts/package_files.py --cargo $(CARGO)
	rm -f $(WHEEL_DIR)/chainsweep-*.whl
	CFLAGS_x86_64_unknown_linux_gnu="$(WHEEL_CFLAGS)" $(VENV)/bin/maturin build --manifest-path python/Cargo.toml --profile wheel \
	  --zig --compatibility manylinux_$(WHEEL_GLIBC) --out $(WHEEL_DIR)
	@ls -l $(WHEEL_DIR)/chainsweep-*.whl

# ncdump (Debian's netcdf-bin): tests/test_xarray.py checks the result files with `ncdump -h`.
# Installed with apt-get when missing (as root, else through sudo); a no-op once installed.
# Installs Debian package $(1) with apt-get, as root or through sudo (updating the package lists
# only when the install fails without it): the one recipe of every system tool the tests need.
apt_install = echo "installing $(1) with apt-get"; \
  sudo=$$([ "$$(id -u)" -eq 0 ] || echo sudo); \
  export DEBIAN_FRONTEND=noninteractive; \
  $$sudo apt-get install -y -q $(1) >/dev/null 2>&1 || \
  { $$sudo apt-get update -q && $$sudo apt-get install -y -q $(1); }

NCDUMP_PACKAGE := netcdf-bin
ncdump:
	@command -v ncdump >/dev/null 2>&1 || { $(call apt_install,$(NCDUMP_PACKAGE)); }

# UDUNITS-2 (Debian's libudunits2-0, with its units database): cfunits, with which cfchecker
# (requirements.txt) checks the units of the result files in tests/test_cf.py, loads the C library.
# Installed with apt-get when missing, as ncdump is; a no-op once installed.
UDUNITS_PACKAGE := libudunits2-0
.PHONY: udunits
udunits:
	@/sbin/ldconfig -p | grep -q 'libudunits2\.so' || { $(call apt_install,$(UDUNITS_PACKAGE)); }
test-python: udunits

# Chromium (Debian's chromium): tests/test_report.py loads the pages of `chainsweep report` in it,
# headless. Installed with apt-get when missing, as ncdump is; a no-op once installed.
CHROMIUM_PACKAGE := chromium
.PHONY: chromium
chromium:
	@command -v chromium >/dev/null 2>&1 || { $(call apt_install,$(CHROMIUM_PACKAGE)); }
test-python: chromium

# Python tests (tests/): h5py round trips of the sweep runner's HDF5 files, kill-and-resume,
# --jobs and shard/merge bitwise identity, the malformed-sweep corpus, the docs' snippets. They run
# the release binary. tests/python/: the Python package (run, sweep, open against the binary) and
# the examples, against `make python`'s build installed into .venv (compiled in the workspace's
# target directory: the engine and HDF5 once, for the binary and the package).
# One pytest process per core (pytest-xdist), each test file whole in one of them (--dist loadfile:
# a file's module fixtures are made once, and the SLURM tests' cluster is started once).
PYTEST_WORKERS ?= auto
CHAINSWEEP_BIN ?= $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/release/chainsweep
PYTEST = CHAINSWEEP_BIN=$(CHAINSWEEP_BIN) CHAINSWEEP_WHEEL_DIR=$(CURDIR)/$(WHEEL_DIR) \
  $(PY) -m pytest -q -n $(PYTEST_WORKERS) --dist loadfile

test-python: bin python ncdump
	$(PYTEST) -m "not system" tests

# The everyday tier: what a change needs (formatting, clippy's lints over the units it builds, the
# Rust tests, the Python tests, the docs' snippets), a few minutes on two cores.
test: fmt-check lint-canary test-rust test-python

# The system tier: the wheel built (zig, manylinux) and installed into a clean venv, a real SLURM
# cluster, a full disk (a tmpfs: root), files of hundreds of MB, the random byte-flip campaign,
# and clippy over every target. .ci/run runs both tiers.
test-system: lint-all bin python ncdump wheel strace
	$(PYTEST) -m system tests

# strace (Debian's strace): tests/test_store.py fails one write of a publish with it (its fault
# injection), as a failing disk would. Installed with apt-get when missing, as ncdump is.
STRACE_PACKAGE := strace
.PHONY: strace
strace:
	@command -v strace >/dev/null 2>&1 || { $(call apt_install,$(STRACE_PACKAGE)); }

# The solver's bench at BENCH_BASE (built in a temporary git worktree) and at the working tree, run
# alternately BENCH_ROUNDS times; medians side by side (scripts/bench_compare.py). After a merge,
# give the commit before it: make bench BENCH_BASE=<commit>. Then the default, no-FMA (portable)
# and target-cpu=native builds side by side (scripts/bench_builds.sh); BENCH_BASELINE=REV adds a
# build of revision REV to that table (e.g. the tag first-release, the first release's build).
BENCH_BASE ?= main
BENCH_ROUNDS ?= 5
BENCH_BASELINE ?=
bench: venv python $(VENV)/.bench-stamp
	$(PY) scripts/bench_compare.py --base $(BENCH_BASE) --rounds $(BENCH_ROUNDS)
	BENCH_BASELINE=$(BENCH_BASELINE) CARGO=$(CARGO) scripts/bench_builds.sh
	$(PY) scripts/bench_store.py --base-bin $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/bench-base/release/chainsweep
	$(PY) scripts/bench_history_filters.py
	$(PY) scripts/bench_scipy.py
	$(PY) scripts/bench_call.py
	$(PY) scripts/bench_fit.py --whole-runs
	$(PY) scripts/bench_ensemble.py
	$(PY) scripts/bench_periodic.py
	$(PY) scripts/bench_long_runs.py --base-bin $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/bench-base/release/chainsweep
	$(PY) scripts/bench_numba_lsoda.py --base-bin $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/bench-base/release/chainsweep

# The Fig. 8 sweep against numba + numbalsoda LSODA (scripts/bench_numba_lsoda.py): numba and
# numbalsoda from requirements-bench.txt into .venv. pip builds numbalsoda from source, with a
# Fortran compiler: gfortran (Debian's), installed with apt-get when missing, as ncdump is.
GFORTRAN_PACKAGE := gfortran
.PHONY: gfortran
gfortran:
	@command -v gfortran >/dev/null 2>&1 || { $(call apt_install,$(GFORTRAN_PACKAGE)); }

$(VENV)/.bench-stamp: requirements-bench.txt $(VENV)/.stamp | gfortran
	$(VENV)/bin/pip install --quiet -r requirements-bench.txt
	touch $@

clean:
	$(CARGO) clean
	rm -rf $(VENV) $(WHEEL_DIR)

# ---------------------------------------------------------------------------------------------
# The paper's figures and numbers. Every sweep file below runs into results/NAME.h5;
# a finished sweep resumes instantly, so both targets can be run again at no cost. A sweep with
# failed runs (exit 3) is reported and the plots still drawn; the target then fails at the end.
# SWEEP_JOBS sets the parallel runs per sweep (default: 2).
SWEEP_JOBS ?= 2
PAPER_SWEEPS := fig08 fig08-literal fig08-choices fig08-light fig15 fig17 fig18 fig19 \
	critical-damping text-098 text-098-variants text-055 preload fig07 fig14 fig16 long-chain
PAPER_PLOTS := fig08.py "fig_compare.py fig15 fig17 fig18 fig19" fig07.py fig14.py fig16.py long_chain.py

# (one shell: `partial` collects the sweeps whose runs partly failed)
RUN_PAPER_SWEEPS = mkdir -p results; partial=""; \
	for s in $(PAPER_SWEEPS); do \
	  echo "sweep $$s"; \
	  $(CHAINSWEEP_BIN) run sweeps/$$s.json -o results/$$s.h5 --jobs $(SWEEP_JOBS) --quiet; rc=$$?; \
	  if [ $$rc -eq 3 ]; then echo "WARNING: sweep $$s: some runs failed (chainsweep status results/$$s.h5)"; \
	    partial="$$partial $$s"; \
	  elif [ $$rc -ne 0 ]; then echo "ERROR: sweep $$s failed (exit $$rc)"; exit $$rc; fi; \
	done

.PHONY: paper-check

# Chains beyond the paper's (docs/CHAINS.md): every sweep of sweeps/examples/ into
# results/examples/NAME.h5, then one figure each into results/examples/NAME.png and the
# attenuation table of the delta-force dimer; the search examples (docs/SEARCHES.md) drawn with
# their points and the minima and roots they found; the fits with their data, residuals and
# profiles; the ensembles' distribution and Sobol' indices. About a minute and a half on two cores.
EXAMPLE_SWEEPS := trimer tapered disordered precompressed dimer-impulse \
  dimer-minimum critical-damping-root fig08-refined fig08-surface alternating-dimer-minimum \
  plastic-impact dimer-bands colliding-waves between-walls driven-sweep-up-down driven-branches dimer-breathers \
  dimer-transmission load-cell-impact fit-damping fit-striker-velocity fit-signal fit-spectrum \
  ensemble-tolerance ensemble-tolerance-monte-carlo ensemble-sensitivity

# The reference renderings the docs show, docs/figures/ (tracked; results/ is not): each of them
# copied from results/ where `make figures`, `make examples` or `make accuracy` has drawn it.
docs-figures:
	@cd docs/figures && for f in $$(find . -name '*.png' | sort); do \
	  if [ -f ../../results/$$f ]; then cp ../../results/$$f $$f; echo "docs/figures/$${f#./}"; \
	  else echo "not drawn yet: results/$${f#./}"; fi; \
	done
.PHONY: docs-figures

# Examples whose sweep is expected to leave some steady states unsettled (exit 3): the dimer's
# far end deep in its band gap, where the tiny forced response stays below the slowest modes
# still ringing from the start. Their other runs must all be ok (no failed or pending run).
EXAMPLES_WITH_UNSETTLED := dimer-transmission
examples: build
	@mkdir -p results/examples; \
	for s in $(EXAMPLE_SWEEPS); do \
	  echo "example $$s"; \
	  $(CHAINSWEEP_BIN) run sweeps/examples/$$s.json -o results/examples/$$s.h5 --jobs $(SWEEP_JOBS) --quiet; rc=$$?; \
	  if [ $$rc -eq 3 ] && echo " $(EXAMPLES_WITH_UNSETTLED) " | grep -q " $$s " && \
	     $(CHAINSWEEP_BIN) status results/examples/$$s.h5 --json | $(PY) -c 'import json,sys; c=json.load(sys.stdin)["counts"]; sys.exit(c["failed"] + c["pending"] > 0)'; then \
	    echo "  (some steady states unsettled, as expected: drawn hollow)"; \
	  elif [ $$rc -ne 0 ]; then echo "ERROR: example $$s failed (exit $$rc)"; exit 1; fi; \
	done; \
	cd scripts && ../$(PY) examples.py

figures: build
	@$(RUN_PAPER_SWEEPS); \
	cd scripts && for p in $(PAPER_PLOTS); do ../$(PY) $$p || exit 1; done; \
	if [ -n "$$partial" ]; then echo "ERROR: sweeps with failed runs:$$partial (plots drawn from the runs that succeeded)"; exit 3; fi

paper-check: build
	@$(RUN_PAPER_SWEEPS); \
	cd scripts && ../$(PY) paper_check.py || exit 1; \
	if [ -n "$$partial" ]; then echo "ERROR: sweeps with failed runs:$$partial"; exit 3; fi

# Work-precision studies: every integrator over a ladder of settings on the Fig. 8 and
# Fig. 15 scenes and on damping-dominated light chains. HDF5, tables and logs go to
# results/accuracy/, plots to results/work_precision_*.png. See docs/NUMERICS.md.
ACCURACY_SCENES := fig08 fig15 stiff-100 stiff-1000 stiff-10000
.PHONY: accuracy
accuracy: build
	@mkdir -p results/accuracy
	for s in $(ACCURACY_SCENES); do \
	  $(CHAINSWEEP_BIN) accuracy sweeps/stress/work-precision/$$s.json -o results/accuracy/work_precision_$$s.h5 \
	    2> results/accuracy/work_precision_$$s.log | tee results/accuracy/work_precision_$$s.txt || exit 1; \
	  $(PY) scripts/plot_work_precision.py results/accuracy/work_precision_$$s.h5 -o results/work_precision_$$s.png || exit 1; \
	done

# integrator: auto: sweeps whose integrator is `auto` with a target relative error, run
# with every point verified at a tighter setting (--verify 1); the check prints the chosen setting
# and the largest verified error, and fails when a point misses the target. See docs/NUMERICS.md.
AUTO_CHECK_SWEEPS := fig08-auto stress/auto-stiff
AUTO_CHECK_PY := import h5py, json, sys, numpy as np; \
	f = h5py.File(sys.argv[1], "r"); t = float(f.attrs["auto_target_rel_error"]); \
	e = np.nanmax(np.stack([f["verify_rel_error_" + n][...] for n in ("leading_peak", "leading_peak_time", "record_max")]), axis=(0, -1)); \
	v = f["verified"][...]; m = float(np.nanmax(e)); \
	i = int(np.nanargmax(e)); a = f.attrs["auto_setting"]; \
	print(f"{sys.argv[1]}: integrator auto, target {t:g}: {a}; " \
	      f"{int((v == 1).sum())}/{v.size} points verified, largest relative error {m:.3g} at point {i}: " \
	      + ("target met" if (v == 1).all() and m <= t else "TARGET MISSED")); \
	sys.exit(0 if (v == 1).all() and m <= t else 1)
.PHONY: auto-check
auto-check: build
	@mkdir -p results; \
	for s in $(AUTO_CHECK_SWEEPS); do \
	  out=results/$$(basename $$s).h5; \
	  $(CHAINSWEEP_BIN) run sweeps/$$s.json -o $$out --jobs $(SWEEP_JOBS) --verify 1 --quiet || exit $$?; \
	  $(PY) -c '$(AUTO_CHECK_PY)' $$out || exit 1; \
	done
