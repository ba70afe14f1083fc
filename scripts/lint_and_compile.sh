#!/bin/sh
# `make test`'s compiler for the workspace's own crates (cargo's RUSTC_WORKSPACE_WRAPPER, so the
# dependencies are compiled by rustc as always and shared with every other release build): clippy's
# driver, which lints as it compiles (CLIPPY_ARGS), with 16 codegen units instead of the release
# profile's one. LLVM then optimises each crate on both cores rather than one: compiling the
# workspace's tests and binaries took 111 s instead of 157 s on two cores. The numbers are the same
# bit for bit (Rust's floating point is IEEE without fast-math, so how a crate is split into units
# changes no result: the paper's bitwise tests run on this build); the shipped builds (`make bin`,
# `make wheel`, `make figures`, `make bench`) keep one unit, the fastest code. Nor debug info
# (the release profile's line tables, kept there for profiling): the tests' panics still name
# their file and line, and rebuilding the tests and binaries after a change to the solver took
# 234 s of CPU instead of 260 s.
# Cargo calls it as `lint_and_compile.sh RUSTC ARGS…`, as it would call clippy's driver.
exec "${CHAINSWEEP_CLIPPY_DRIVER:?the path of clippy-driver, which make test sets}" "$@" -C codegen-units=16 -C debuginfo=0
