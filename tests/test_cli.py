"""The command line: help with examples, validate, dry run, progress output, quiet, status,
usage errors (exit 2, nothing written)."""

import json
import os
import pty
import re
import select
import subprocess
import time

from conftest import BIN, REPO, base_sweep, run, write_sweep


def test_help_has_examples(binary):
    r = run("--help")
    assert r.returncode == 0
    assert "Examples:" in r.stdout and "chainsweep run" in r.stdout and "merge" in r.stdout
    assert "Exit codes" in r.stdout
    for sub in ("run", "validate", "status", "merge", "point"):
        r = run(sub, "--help")
        assert r.returncode == 0, sub
        assert "Example" in r.stdout, sub


def test_usage_errors_exit_2(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    for args in (
        ["run", path, "--jobs", "0"],
        ["run", path, "--shard", "4/3"],
        ["run", path, "--shard", "x"],
        ["run", path, "--no-such-flag"],
        ["run", path, "-o", tmp_path / "missing-dir" / "x.h5"],
        ["frobnicate"],
    ):
        r = run(*args, cwd=tmp_path)
        assert r.returncode == 2, (args, r.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_validate(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("validate", path)
    assert r.returncode == 0, r.stderr
    assert "6 grid points" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_dry_run_prints_grid_and_estimate(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep(history=True))
    r = run("run", path, "--dry-run", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "grid: 6 points (shape 3 × 2)" in r.stdout
    assert "estimated output size" in r.stdout
    assert "mass_ratio=0.55 damping_kg_s=6" in r.stdout
    assert "201 samples" in r.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.json"]


def test_plain_progress_when_not_a_terminal_and_quiet(binary, tmp_path):
    s = base_sweep()
    path = write_sweep(tmp_path / "s.json", s)
    r = run("run", path, "-o", tmp_path / "a.h5", "--jobs", "2", "--progress-interval", "0.01")
    assert r.returncode == 0
    assert "chainsweep: 6/6 runs done, 0 failed" in r.stderr
    assert "runs/s" in r.stderr and "ETA" in r.stderr
    assert "6 runs: 6 ok, 0 failed, 0 pending" in r.stderr
    r = run("run", path, "-o", tmp_path / "b.h5", "--quiet")
    assert r.returncode == 0
    assert r.stderr == "" and r.stdout == ""


def test_progress_bar_on_a_terminal_shows_rates_and_no_empty_fields(binary, tmp_path):
    # A sweep long enough for several frames, its stderr a pseudo-terminal.
    s = base_sweep(cylinders=40, duration_s=1e-3)
    s["axes"][0]["values"] = [0.3 + 0.05 * k for k in range(14)]
    path = write_sweep(tmp_path / "s.json", s)
    controller, terminal = pty.openpty()
    proc = subprocess.Popen(
        [BIN, "run", path, "-o", tmp_path / "a.h5", "--jobs", "1"],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=terminal,
    )
    os.close(terminal)
    screen = b""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        ready, _, _ = select.select([controller], [], [], 0.5)
        if ready:
            try:
                chunk = os.read(controller, 65536)
            except OSError:
                break
            if not chunk:
                break
            screen += chunk
        elif proc.poll() is not None:
            break
    os.close(controller)
    assert proc.wait(timeout=60) == 0
    text = screen.decode(errors="replace")
    frames = [f for f in re.split(r"[\r\n]", text) if "runs," in f]
    assert frames, text
    for frame in frames:
        assert ", ," not in frame, frame
        assert "failed" in frame, frame
        assert re.search(r"\d+ runs/s", frame) or re.search(r"\d\.\d+ runs/s", frame), frame
        # Three significant digits, never indicatif's raw `40.5194/s`.
        assert not re.search(r"\d\.\d{4,}/s", frame), frame


def test_version_names_the_revision(binary):
    r = run("--version")
    assert r.returncode == 0
    rev = subprocess.run(
        ["git", "rev-parse", "--short=12", "HEAD"], cwd=REPO, capture_output=True, text=True
    ).stdout.strip()
    assert re.fullmatch(r"chainsweep \d+\.\d+\.\d+ \(revision \S+\)\n", r.stdout), r.stdout
    assert rev and rev in r.stdout, (rev, r.stdout)


def test_default_output_and_status(binary, tmp_path):
    path = write_sweep(tmp_path / "mysweep.json", base_sweep())
    r = run("status", path, cwd=tmp_path)
    assert r.returncode == 3
    assert "6 runs: 0 done (0 ok, 0 failed), 6 pending" in r.stdout
    r = run("run", path, "--quiet", cwd=tmp_path)
    assert r.returncode == 0
    assert (tmp_path / "mysweep.h5").exists()
    r = run("status", path, cwd=tmp_path)
    assert r.returncode == 0
    assert "6 done (6 ok, 0 failed), 0 pending" in r.stdout
    r = run("status", tmp_path / "mysweep.h5")
    assert r.returncode == 0
    assert "6 done (6 ok, 0 failed), 0 pending" in r.stdout


def test_foreign_output_is_not_overwritten(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    out = tmp_path / "precious.h5"
    out.write_bytes(b"not ours")
    r = run("run", path, "-o", out)
    assert r.returncode == 2
    assert "--overwrite" in r.stderr
    assert out.read_bytes() == b"not ours"
    r = run("run", path, "-o", out, "--overwrite", "--quiet")
    assert r.returncode == 0


def test_point_prints_scene_and_result(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("point", path, 3)
    assert r.returncode == 0
    p = json.loads(r.stdout)
    assert p["grid_index"] == [1, 1]
    assert p["scene"]["physics"]["damping_kg_s"] == 6
    assert p["result"]["ok"] is True
    r = run("point", path, 6)
    assert r.returncode == 2


def test_bash_completion_completes_commands_and_options(binary, tmp_path):
    """The bash script of `chainsweep completions bash`, sourced in a real bash, completes the
    commands, a command's options and a value list (the shells of `completions`)."""
    r = run("completions", "bash")
    assert r.returncode == 0, r.stderr
    script = tmp_path / "chainsweep.bash"
    script.write_text(r.stdout)

    def complete(*words):
        line = " ".join(["chainsweep", *words])
        probe = (
            f"source {script}\n"
            f"COMP_WORDS=(chainsweep {' '.join(words)}); COMP_CWORD={len(words)}\n"
            f"COMP_LINE='{line}'; COMP_POINT={len(line)}\n"
            f"_chainsweep chainsweep '{words[-1]}' '{words[-2] if len(words) > 1 else 'chainsweep'}'\n"
            'printf "%s\\n" "${COMPREPLY[@]}"\n'
        )
        out = subprocess.run(["bash", "-c", probe], capture_output=True, text=True, timeout=30)
        assert out.returncode == 0, out.stderr
        return out.stdout.split()

    assert {"status", "schema"} <= set(complete("s"))
    assert "--dry-run" in complete("run", "--d")
    assert "--json" in complete("status", "--j")
    assert {"bash", "zsh", "fish"} <= set(complete("completions", ""))
    for shell in ("zsh", "fish", "elvish", "powershell"):
        r = run("completions", shell)
        assert r.returncode == 0 and "validate" in r.stdout and "--dry-run" in r.stdout, shell
    r = run("completions", "tcsh")
    assert r.returncode == 2 and "possible values" in r.stderr


def test_man_pages_render_and_cover_every_command(binary, tmp_path):
    r = run("man", tmp_path / "man1")
    assert r.returncode == 0, r.stderr
    pages = sorted(p.name for p in (tmp_path / "man1").iterdir())
    commands = ["accuracy", "completions", "examples", "examples-copy", "gc", "man", "merge", "point", "report",
                "run", "schema", "slurm", "status", "validate"]
    assert pages == sorted(["chainsweep.1"] + [f"chainsweep-{c}.1" for c in commands])
    assert sorted(os.path.basename(x) for x in r.stdout.split()) == pages
    for p in pages:
        page = tmp_path / "man1" / p
        # groff parses every page without a warning (-k: UTF-8 input through preconv, as man does).
        g = subprocess.run(["groff", "-k", "-man", "-Tutf8", "-ww", str(page)], capture_output=True, text=True, timeout=30)
        assert g.returncode == 0 and g.stderr == "", (p, g.stderr)
    text = subprocess.run(["groff", "-k", "-man", "-Tutf8", "-P", "-cbou", str(tmp_path / "man1" / "chainsweep-run.1")],
                          capture_output=True, text=True).stdout
    assert "--retry-failed" in text and "Run again the points whose earlier run failed" in text, text
    assert "0.1.0 (revision" in (tmp_path / "man1" / "chainsweep-run.1").read_text()


def test_examples_are_listed_and_copied_from_the_command_alone(binary, tmp_path):
    # Every sweep file of the repository is listed, by its name under sweeps/.
    r = run("examples", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    listed = {line.split()[0] for line in r.stdout.splitlines() if line.strip()}
    shipped = {p.relative_to(REPO / "sweeps").with_suffix("").as_posix() for p in (REPO / "sweeps").rglob("*.json")}
    assert listed == shipped
    assert all(len(line) < 160 for line in r.stdout.splitlines())
    # The help's first example works in an empty folder: the sweep it then validates is there.
    r = run("examples", "copy", "mass-damping", ".", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert run("validate", "mass-damping.json", cwd=tmp_path).returncode == 0
    # A fit comes with the recordings it reads, and the copy runs as the original does.
    d = tmp_path / "fits"
    r = run("examples", "copy", "fit-signal", d)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in d.iterdir()) == ["fit-signal-gauge21.csv", "fit-signal-gauge5.csv", "fit-signal.json"]
    for p in d.iterdir():
        assert p.read_bytes() == (REPO / "sweeps" / "examples" / p.name).read_bytes()
    assert run("validate", d / "fit-signal.json").returncode == 0
    # Nothing is overwritten: a second copy is refused, naming the file, and changes nothing.
    (d / "fit-signal-gauge5.csv").write_text("mine")
    r = run("examples", "copy", "examples/fit-signal", d)
    assert r.returncode == 2 and "exists" in r.stderr, r.stderr
    assert (d / "fit-signal-gauge5.csv").read_text() == "mine"
    # An unknown name says which there are.
    r = run("examples", "copy", "no-such-example", tmp_path / "x")
    assert r.returncode == 2 and "examples/trimer" in r.stderr, r.stderr
    assert not (tmp_path / "x").exists()
    # all: every file, in its folder.
    r = run("examples", "copy", "all", tmp_path / "all")
    assert r.returncode == 0, r.stderr
    copied = {p.relative_to(tmp_path / "all").as_posix() for p in (tmp_path / "all").rglob("*") if p.is_file()}
    assert {f"{n}.json" for n in shipped} <= copied
    assert "examples/fit-signal-gauge5.csv" in copied


def test_status_of_a_job_folder_before_any_task_ran_counts_its_shards_missing(binary, tmp_path):
    path = write_sweep(tmp_path / "s.json", base_sweep())
    r = run("slurm", path, "-o", tmp_path / "out.h5", "--shards", "4", "--time", "0:10:00")
    assert r.returncode == 0, r.stderr
    job = tmp_path / "out.h5.slurm"
    r = run("status", job)
    assert r.returncode == 3, r.stderr
    assert "4 shards: 0 done, 0 failed, 0 running, 0 pending, 4 missing" in r.stdout, r.stdout
    assert "sbatch --parsable --array=0,1,2,3" in r.stderr, r.stderr
    js = json.loads(run("status", job, "--json").stdout)
    assert [s["state"] for s in js["list"]] == ["missing"] * 4
    assert [s["array_task"] for s in js["list"]] == [0, 1, 2, 3]
    # Once a shard is there, the folder is read as before: the others are still missing.
    first = sorted((job / "shards.txt").read_text().split())[0]
    assert run("run", path, "--shard", "1/4", "-o", first, "--quiet").returncode == 0
    r = run("status", job)
    assert "1 done" in r.stdout and "3 missing" in r.stdout, r.stdout


def test_status_tells_a_running_sweep_from_an_interrupted_one(binary, tmp_path):
    from conftest import interruptible_sweep, segment_count

    path = write_sweep(tmp_path / "s.json", interruptible_sweep())
    out = tmp_path / "s.h5"
    # Checkpoints every 50 ms: the file exists while the sweep runs.
    p = subprocess.Popen([str(BIN), "run", str(path), "-o", str(out), "--jobs", "1", "--quiet",
                          "--checkpoint-interval", "0.05"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while (segment_count(out) < 5 or not out.exists()) and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert p.poll() is None, "the sweep ended before status could see it running"
        running = [run("status", out), run("status", path, "-o", out)]
        js = [json.loads(run("status", out, "--json").stdout),
              json.loads(run("status", path, "-o", out, "--json").stdout)]
    finally:
        p.kill()
        p.communicate()
    assert f"a sweep is writing this file now (process {p.pid})" in running[0].stdout, running[0].stdout
    assert f"a sweep is running into this output now (process {p.pid})" in running[1].stdout, running[1].stdout
    assert [j["writer_pid"] for j in js] == [str(p.pid)] * 2
    # Killed: no process holds it; the runs it finished after its last checkpoint are the
    # interrupted sweep's, and status says so.
    r = run("status", out)
    js = json.loads(run("status", out, "--json").stdout)
    assert js["writer_pid"] is None
    assert "writing this file now" not in r.stdout
    if js["finished_since_written"] > 0:
        assert "the sweep was interrupted" in r.stdout, r.stdout
