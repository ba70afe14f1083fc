# chainsweep — one entry point for building, testing, benchmarking and the paper's figures.
#
#   make test      builds everything (installing what it needs into .venv) and runs every test
#   make figures   runs the paper's sweeps on a small default and draws the figures into results/
#   make bench     benchmarks (criterion): right-hand-side cost and the reference run
#
# The HDF5 library is built from source (hdf5-metno's `static` feature) and needs CMake >= 3.26;
# when the machine has none or an older one, CMake comes from PyPI into .venv.

SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
CMAKE_MIN := 3.26
CARGO ?= cargo

export PATH := $(CURDIR)/$(VENV)/bin:$(PATH)

.PHONY: all build test test-rust test-python bench figures fmt lint venv clean

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

fmt:
	$(CARGO) fmt --all

# Every cargo step uses the release profile: the HDF5 C library is then compiled once (minutes on
# two cores), not once per profile, and the physics tests run at full speed.
lint: venv
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --workspace --all-targets -- -D warnings

test-rust: venv
	$(CARGO) test --release --workspace

# Python tests (tests/): h5py round trips of the sweep runner's HDF5 files, kill-and-resume,
# --jobs and shard/merge bitwise identity, the malformed-sweep corpus. They run the release binary.
CHAINSWEEP_BIN ?= $(or $(CARGO_TARGET_DIR),$(CURDIR)/target)/release/chainsweep

test-python: build
	CHAINSWEEP_BIN=$(CHAINSWEEP_BIN) $(PY) -m pytest -q tests

test: lint test-rust test-python

bench: venv
	$(CARGO) bench -p chainsweep-solver --bench solver

clean:
	$(CARGO) clean
	rm -rf $(VENV)
