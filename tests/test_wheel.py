"""The wheel of `make wheel`, as a user of a cluster gets it: installed with pip into a clean venv
on a PATH without Rust (no cargo, no rustc), it gives `import chainsweep` and the `chainsweep`
command, which validate, run and resume a sweep, stop on SIGINT and SIGTERM as the native binary
does, and compute bitwise what the native binary computes.

The wheel itself: tagged abi3 and manylinux no newer than glibc 2.28, a tag `auditwheel show`
confirms and the extension's versioned glibc symbols respect; the extension stripped; the
`chainsweep` console script; the licences (the project's, HDF5's and zlib's); the example sweeps
and the guides, byte for byte the repository's.

`make test` builds the wheel first (CHAINSWEEP_WHEEL_DIR names its folder); run alone, this file
runs `make wheel` itself.
"""

import json
import os
import re
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

from conftest import (
    REPO,
    VOLATILE_ATTRS,
    assert_files_equal,
    base_sweep,
    interruptible_sweep,
    run,
    segment_count,
    write_sweep,
)

# The system tier (`make test-system`): the wheel built by zig and installed in a clean venv.
pytestmark = pytest.mark.system

WHEEL_DIR = Path(os.environ.get("CHAINSWEEP_WHEEL_DIR", REPO / "dist"))
# Newest glibc a wheel for the clusters may ask for (RHEL/Rocky 8, Debian 10, Ubuntu 18.10).
NEWEST_GLIBC = (2, 28)
# Attributes that name the build (`git describe` of the tree each was built from): the wheel and
# the binary may be built a commit apart.
BUILD_ATTRS = {"git_revision"}

# Rust's and make's variables: none reaches the clean venv.
DROPPED_ENV = re.compile(r"^(CARGO|RUSTUP|RUSTC|RUSTDOC|RUSTFLAGS|PYO3_|MAKE|MFLAGS|VIRTUAL_ENV|PYTHON|CHAINSWEEP_)")


@pytest.fixture(scope="module")
def wheel():
    if "CHAINSWEEP_WHEEL_DIR" not in os.environ:
        env = {k: v for k, v in os.environ.items() if not re.match(r"^(MAKE|MFLAGS)", k)}
        t0 = time.time()
        r = subprocess.run(["make", "wheel"], cwd=REPO, env=env, capture_output=True, text=True, timeout=1800)
        assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-4000:]
        print(f"make wheel: {time.time() - t0:.0f} s")
    wheels = sorted(WHEEL_DIR.glob("chainsweep-*.whl"))
    assert len(wheels) == 1, f"expected one wheel in {WHEEL_DIR}, found {wheels}"
    w = wheels[0]
    print(f"{w.name}: {w.stat().st_size / 1e6:.2f} MB")
    return w


def wheel_tags(w):
    """The platform tags of a wheel's file name, and its python and ABI tags."""
    name, version, py, abi, plat = w.name[: -len(".whl")].split("-")
    return py, abi, plat.split(".")


def glibc_of(platform_tag):
    """(2, 17) of manylinux_2_17_x86_64 and of manylinux2014_x86_64."""
    legacy = {"manylinux1": (2, 5), "manylinux2010": (2, 12), "manylinux2014": (2, 17)}
    m = re.fullmatch(r"manylinux_(\d+)_(\d+)_x86_64", platform_tag)
    if m:
        return int(m[1]), int(m[2])
    m = re.fullmatch(r"(manylinux\d+)_x86_64", platform_tag)
    assert m and m[1] in legacy, f"not a manylinux x86_64 tag: {platform_tag}"
    return legacy[m[1]]


def test_the_wheel_is_abi3_and_manylinux_as_auditwheel_confirms(wheel, tmp_path):
    py, abi, platforms = wheel_tags(wheel)
    assert (py, abi) == ("cp310", "abi3"), wheel.name
    claimed = [glibc_of(p) for p in platforms]
    assert max(claimed) <= NEWEST_GLIBC, wheel.name
    with zipfile.ZipFile(wheel) as z:
        meta = z.read(next(n for n in z.namelist() if n.endswith(".dist-info/WHEEL"))).decode()
    assert sorted(re.findall(r"^Tag: (.+)$", meta, re.M)) == sorted(f"{py}-{abi}-{p}" for p in platforms)

    # auditwheel (requirements-wheel.txt): the oldest platform the wheel is consistent with, from
    # its libraries and their versioned symbols, must be no newer than every tag it claims.
    r = subprocess.run([sys.executable, "-m", "auditwheel", "show", str(wheel)], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    text = " ".join(r.stdout.split())
    print(text)
    m = re.search(r'consistent with the following platform tag: "(manylinux_\d+_\d+_x86_64)"', text)
    assert m, text
    assert glibc_of(m[1]) <= min(claimed), f"auditwheel: {m[1]}; the wheel claims {platforms}"

    # The same from the extension's symbols: no glibc symbol version newer than the tag.
    from elftools.elf.elffile import ELFFile  # auditwheel's dependency

    with zipfile.ZipFile(wheel) as z:
        so = [n for n in z.namelist() if n.startswith("chainsweep/_chainsweep") and n.endswith(".so")]
        assert so == ["chainsweep/_chainsweep.abi3.so"], so
        ext = tmp_path / "ext.so"
        ext.write_bytes(z.read(so[0]))
    versions = set()
    with open(ext, "rb") as f:
        elf = ELFFile(f)
        needed = set()
        for sec in elf.iter_sections():
            if sec.name == ".gnu.version_r":
                for verneed, auxs in sec.iter_versions():
                    needed.add(verneed.name)
                    versions |= {a.name for a in auxs if a.name.startswith("GLIBC_")}
        names = {sec.name for sec in elf.iter_sections()}
    newest = max(tuple(int(x) for x in v[len("GLIBC_") :].split(".")[:2]) for v in versions)
    print(f"extension: {ext.stat().st_size / 1e6:.2f} MB, needs {sorted(needed)}, newest glibc symbol {newest}")
    assert newest <= min(claimed), (newest, platforms)
    # Only the C library (and its parts): HDF5 and zlib are linked in.
    system = {"libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1", "libgcc_s.so.1", "ld-linux-x86-64.so.2"}
    assert needed <= system, needed
    # Stripped: no symbol table, no debug information.
    assert ".symtab" not in names and not any(n.startswith(".debug") for n in names), sorted(names)


def test_the_wheel_carries_the_command_licences_examples_and_guides(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = set(z.namelist())
        info = next(n for n in names if n.endswith(".dist-info/METADATA")).rsplit("/", 1)[0]
        read = lambda n: z.read(n)  # noqa: E731
        meta = read(f"{info}/METADATA").decode()
        entry = read(f"{info}/entry_points.txt").decode()
        assert re.search(r"^\[console_scripts\]\s*^chainsweep\s*=\s*chainsweep\._cli:main\s*$", entry, re.M), entry
        assert "License-Expression: MIT OR Apache-2.0" in meta
        licences = {
            "LICENSE-MIT": "Permission is hereby granted, free of charge",
            "LICENSE-APACHE": "Apache License",
            "licenses/HDF5/COPYING": "HDF5 (Hierarchical Data Format 5) Software Library and Utilities",
            "licenses/HDF5/COPYING_LBNL_HDF5": "Lawrence Berkeley National Laboratory",
            "licenses/zlib/LICENSE": "Jean-loup Gailly and Mark Adler",
            "licenses/DejaVu/LICENSE": "Bitstream Vera",
            "licenses/rust-crates/THIRD-PARTY-LICENSES.txt": "Third-party software compiled into chainsweep",
        }
        for lic, phrase in licences.items():
            assert f"License-File: {lic}" in meta, lic
            assert phrase in read(f"{info}/licenses/{lic}").decode(errors="replace"), lic
        assert read(f"{info}/licenses/LICENSE-MIT") == (REPO / "LICENSE-MIT").read_bytes()
        assert read(f"{info}/licenses/LICENSE-APACHE") == (REPO / "LICENSE-APACHE").read_bytes()
        # Every Rust crate compiled into the extension is named with its licence (a few that
        # must be there: the engine's HDF5 binding, the Python binding, the parallel runner).
        third = read(f"{info}/licenses/licenses/rust-crates/THIRD-PARTY-LICENSES.txt").decode()
        for crate in ("hdf5-metno", "pyo3", "rayon", "serde_json", "schemars"):
            assert re.search(rf"^{crate} [0-9.]+ \(", third, re.M), crate

        # The example sweeps and the guides, as in the repository, and nothing stale beside them.
        sweeps = {f"chainsweep/sweeps/{p.relative_to(REPO / 'sweeps').as_posix()}": p for p in (REPO / "sweeps").rglob("*.json")}
        docs = {f"chainsweep/docs/{p.name}": p for p in (REPO / "docs").glob("*.md")}
        assert "chainsweep/sweeps/mass-damping.json" in sweeps and "chainsweep/docs/PYTHON.md" in docs
        scripts = {f"chainsweep/example_scripts/{p.name}": p for p in (REPO / "examples").glob("*.py")}
        assert "chainsweep/example_scripts/fig08.py" in scripts
        assert "chainsweep/example_scripts/__init__.py" in names
        for name, src in {**sweeps, **docs, **scripts}.items():
            assert name in names, name
            assert read(name) == src.read_bytes(), f"{name} differs from {src.relative_to(REPO)}"
        shipped = {n for n in names if n.startswith(("chainsweep/sweeps/", "chainsweep/docs/")) and n.endswith((".json", ".md"))}
        assert shipped <= set(sweeps) | set(docs) | {n for n in names if n.startswith("chainsweep/docs/") and n.endswith(".json")}
        assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]


def clean_env(venv):
    """The environment of a machine without Rust: the venv first on PATH, then only the folders
    that hold no cargo, rustc or rustup (nor this repository's .venv); no Rust or make variables."""
    keep = []
    for d in os.environ.get("PATH", "").split(os.pathsep):
        if not d or Path(d).resolve() == (REPO / ".venv" / "bin").resolve():
            continue
        if any((Path(d) / tool).exists() for tool in ("cargo", "rustc", "rustup")):
            continue
        keep.append(d)
    env = {k: v for k, v in os.environ.items() if not DROPPED_ENV.match(k)}
    env["PATH"] = os.pathsep.join([str(venv / "bin"), *keep])
    return env


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory):
    """A clean venv (no system site packages) with the wheel installed by pip, binaries only."""
    d = tmp_path_factory.mktemp("wheel")
    v = d / "venv"
    t0 = time.time()
    subprocess.run([sys.executable, "-m", "venv", str(v)], check=True, env=clean_env(v))
    t1 = time.time()
    r = subprocess.run(
        [str(v / "bin" / "python"), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
         "--only-binary", ":all:", str(wheel)],
        env=clean_env(v), capture_output=True, text=True, timeout=900,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    print(f"clean venv: created in {t1 - t0:.1f} s, the wheel and its dependencies installed in {time.time() - t1:.1f} s")
    return v


def in_venv(v, *args, cwd=None, timeout=300, **popen):
    return subprocess.run([str(a) for a in args], env=clean_env(v), cwd=cwd, capture_output=True, text=True, timeout=timeout, **popen)


def test_there_is_no_rust_in_the_venv(venv):
    r = in_venv(venv, venv / "bin" / "python", "-c",
                "import shutil, sys; sys.exit(0 if shutil.which('cargo') is None and shutil.which('rustc') is None else 1)")
    assert r.returncode == 0, "cargo or rustc is reachable from the clean venv"
    r = in_venv(venv, venv / "bin" / "python", "-c", "import chainsweep, sys; print(chainsweep.__file__)")
    assert r.returncode == 0, r.stderr
    assert Path(r.stdout.strip()).resolve().is_relative_to(venv.resolve()), r.stdout


def test_the_command_and_the_package_run_a_sweep_as_the_binary_does(venv, tmp_path, binary):
    cmd = venv / "bin" / "chainsweep"
    assert cmd.is_file()
    r = in_venv(venv, cmd, "--version")
    assert r.returncode == 0 and re.match(r"chainsweep \d+\.\d+\.\d+ \(revision ", r.stdout), r.stdout + r.stderr
    r2 = in_venv(venv, venv / "bin" / "python", "-m", "chainsweep", "--version")
    assert (r2.returncode, r2.stdout) == (0, r.stdout), r2.stderr
    r3 = in_venv(venv, venv / "bin" / "python", "-c", "import chainsweep; print(chainsweep.__version__)")
    assert r.stdout.split()[1] == r3.stdout.strip(), (r.stdout, r3.stdout)
    r = in_venv(venv, cmd, "--help")
    assert r.returncode == 0 and "Usage: chainsweep" in r.stdout, r.stdout + r.stderr
    r = in_venv(venv, cmd, "frobnicate")
    assert r.returncode == 2 and "unrecognized subcommand" in r.stderr, r.stdout + r.stderr

    path = write_sweep(tmp_path / "tiny.json", base_sweep())
    out = tmp_path / "tiny.h5"
    t0 = time.time()
    r = in_venv(venv, cmd, "validate", path)
    assert r.returncode == 0, r.stdout + r.stderr
    r = in_venv(venv, cmd, "run", path, "-o", out, "--jobs", "2", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "6 runs" in r.stderr and "6 ok" in r.stderr, r.stderr
    r = in_venv(venv, cmd, "status", out)
    assert r.returncode == 0 and "done" in r.stdout, r.stdout + r.stderr
    print(f"validate, run, status of a 6-run sweep through the console script: {time.time() - t0:.1f} s")

    # The package reads it, labelled.
    r = in_venv(venv, venv / "bin" / "python", "-c", """if True:
        import json, sys, numpy as np, chainsweep
        ds = chainsweep.open(sys.argv[1])
        peak = ds.leading_peak.sel(probe="gauge_force_cyl2")
        print(json.dumps({"dims": dict(ds.sizes), "finite": bool(np.isfinite(peak.values).all()),
                          "probes": [str(p) for p in ds.probe.values]}))
        """, out)
    assert r.returncode == 0, r.stderr
    got = json.loads(r.stdout)
    assert got["dims"]["mass_ratio"] == 3 and got["dims"]["damping_kg_s"] == 2, got
    assert got["finite"] and got["probes"] == ["gauge_force_cyl2", "gauge_force_cyl8"], got

    # The same engine: bitwise the native binary's numbers.
    native = tmp_path / "native.h5"
    r = run("run", path, "-o", native, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    assert_files_equal(native, out, skip_attrs=VOLATILE_ATTRS | BUILD_ATTRS)


def test_the_all_extra_gives_the_readers_the_guides_use(wheel, tmp_path):
    """`pip install 'chainsweep[all]'` into a clean venv gives what the guides' reading code
    imports: histories read lazily through dask (the same numbers as read whole), xarray's own
    h5netcdf engine, matplotlib for `chainsweep.plot`, tqdm for progress bars."""
    v = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(v)], check=True, env=clean_env(v))
    r = subprocess.run(
        [str(v / "bin" / "python"), "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
         "--only-binary", ":all:", f"{wheel}[all]"],
        env=clean_env(v), capture_output=True, text=True, timeout=900,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    path = write_sweep(tmp_path / "histories.json", base_sweep(history=True))
    out = tmp_path / "histories.h5"
    r = in_venv(v, v / "bin" / "chainsweep", "run", path, "-o", out, "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r = in_venv(v, v / "bin" / "python", "-c", """if True:
        import sys, dask.array, numpy as np, matplotlib, tqdm, xarray as xr, chainsweep
        matplotlib.use("Agg")
        lazy = chainsweep.open(sys.argv[1], histories="lazy")
        whole = chainsweep.open(sys.argv[1], histories=True)
        assert isinstance(lazy.history.data, dask.array.Array), type(lazy.history.data)
        assert np.array_equal(lazy.history.values, whole.history.values, equal_nan=True)
        with xr.open_dataset(sys.argv[1], engine="h5netcdf") as raw:
            assert np.array_equal(raw.leading_peak.values, whole.leading_peak.values, equal_nan=True)
        figures = chainsweep.plot(whole, variables=["leading_peak"])
        print(len(figures), lazy.history.shape)
        """, out)
    assert r.returncode == 0, r.stdout + r.stderr
    assert int(r.stdout.split()[0]) >= 1, r.stdout


def test_the_examples_and_guides_are_installed_and_every_example_validates(venv):
    r = in_venv(venv, venv / "bin" / "python", "-c", """if True:
        import json, chainsweep
        from chainsweep._chainsweep import cli_main
        names = chainsweep.examples()
        bad = [n for n in names if cli_main(["chainsweep", "validate", str(chainsweep.example_path(n))]) != 0]
        print(json.dumps({"names": names, "bad": bad,
                          "mass": str(chainsweep.example_path("mass-damping")),
                          "trimer": str(chainsweep.example_path("examples/trimer.json")),
                          "guide": str(chainsweep.docs_path("REFERENCE")),
                          "python": chainsweep.docs_path("PYTHON").read_text()[:200]}))
        """)
    assert r.returncode == 0, r.stderr[-3000:]
    got = json.loads(r.stdout.strip().splitlines()[-1])
    repo = sorted(p.relative_to(REPO / "sweeps").with_suffix("").as_posix() for p in (REPO / "sweeps").rglob("*.json"))
    assert got["names"] == repo
    assert got["bad"] == [], got["bad"]
    assert Path(got["mass"]).read_bytes() == (REPO / "sweeps" / "mass-damping.json").read_bytes()
    assert Path(got["trimer"]).read_bytes() == (REPO / "sweeps" / "examples" / "trimer.json").read_bytes()
    assert Path(got["guide"]).read_bytes() == (REPO / "docs" / "REFERENCE.md").read_bytes()
    assert got["python"] == (REPO / "docs" / "PYTHON.md").read_text()[:200]
    r = in_venv(venv, venv / "bin" / "python", "-c", "import chainsweep; chainsweep.example_path('no-such-sweep')")
    assert r.returncode == 1 and "FileNotFoundError" in r.stderr and "mass-damping" in r.stderr, r.stderr


@pytest.fixture(scope="module")
def reference(tmp_path_factory, binary):
    """The interruptible sweep, run to the end by the native binary."""
    d = tmp_path_factory.mktemp("wheel-ref")
    path = write_sweep(d / "stop.json", interruptible_sweep())
    out = d / "ref.h5"
    r = run("run", path, "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("sig,code,name", [(signal.SIGINT, 130, "SIGINT"), (signal.SIGTERM, 143, "SIGTERM")])
def test_a_signal_to_the_command_stops_the_sweep_resumably(venv, reference, tmp_path, sig, code, name):
    """As tests/test_signals.py for the binary: Python's own SIGINT handler (KeyboardInterrupt)
    must not take over from the engine's."""
    path = write_sweep(tmp_path / "stop.json", interruptible_sweep())
    out = tmp_path / "out.h5"
    args = [str(venv / "bin" / "chainsweep"), "run", str(path), "-o", str(out), "--jobs", "2", "--checkpoint-interval", "0"]
    p = subprocess.Popen(args, env=clean_env(venv), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while segment_count(out) < 10:
        assert p.poll() is None, "the sweep ended before it could be interrupted"
        assert time.time() < deadline, "the sweep made no progress"
        time.sleep(0.002)
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert f"stopped by {name}" in err and "run the same command to resume" in err, err
    assert "KeyboardInterrupt" not in err and "Traceback" not in err, err
    r = subprocess.run(args[:-2] + ["--quiet"], env=clean_env(venv), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert_files_equal(reference, out, skip_attrs=VOLATILE_ATTRS | BUILD_ATTRS)


def test_the_slurm_job_scripts_run_the_installed_command(venv, tmp_path):
    path = write_sweep(tmp_path / "tiny.json", base_sweep())
    r = in_venv(venv, venv / "bin" / "chainsweep", "slurm", path, "-o", tmp_path / "tiny.h5", "--shards", "2")
    assert r.returncode == 0, r.stdout + r.stderr
    scripts = sorted((tmp_path / "tiny.h5.slurm").glob("*.sh"))
    assert len(scripts) == 2, scripts
    for s in scripts:
        execs = [l for l in s.read_text().splitlines() if l.startswith("exec ")]
        assert len(execs) == 1, s
        program = execs[0].split()[1].strip("'")
        assert Path(program) == (venv / "bin" / "chainsweep").resolve(), execs[0]
