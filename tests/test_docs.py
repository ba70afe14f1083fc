"""The guides cannot go stale: every JSON snippet of the README and of docs/ is a sweep file, or a
part of one, that `chainsweep validate` accepts, and every command shown with its output
(`$ command` and the lines after it) prints that output when run.

A snippet that is a part of a sweep file says, in an HTML comment on the line before it, where it
goes, which no reader of the rendered page sees:

    <!-- checked: into sweeps/examples/trimer.json at base -->
    <!-- checked: into sweeps/examples/trimer.json -->
    <!-- checked: into the snippet above at base.chain -->
    <!-- checked: into sweeps/examples/fit-damping.json at search.data, as a list -->
    <!-- checked: into sweeps/examples/trimer.json at base, with the next snippet -->
    <!-- checked: into sweeps/examples/driven-sweep-up-down.json at base, without its axes -->

The snippet is pasted into that sweep file (its keys replace the file's at that place; `…` keeps
what the file has there) and the result validated; "with the next snippet" validates it only
together with the one that follows (a chain whose contact rules come next); "without its axes"
checks a base scene alone, where the file's axes set what the snippet replaces. A snippet that is a
whole sweep file is validated as it stands, beside the example sweeps (whose data files it may
name).

In a shown output, `…` stands for any text (a time, a path, what depends on the machine), and
numbers are compared to 6 significant digits, the digits beyond depending on the machine's
floating-point unit.
"""

from __future__ import annotations

import copy
import json
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest

from conftest import BIN, REPO

DOCS = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md")), REPO / "python" / "README.md"]
ELLIPSIS = "…"
CHECKED = re.compile(r"<!-- checked: into (?P<into>.+?)(?: at (?P<at>[\w.]+))?(?P<lines>, as a list)?(?P<alone>, without its axes)?"
                     r"(?P<next>, with the next snippet)? -->")


def fenced(text: str):
    """(language, body, line number, the line before the fence) of each fenced block."""
    for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, flags=re.M | re.S):
        start = text[:m.start()].count("\n")
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        yield m.group(1), m.group(2), start + 1, before


def parse_fragment(body: str, as_list: bool):
    """A snippet as JSON: `{…}` and `{ … words … }` are elided values, a trailing `, …` an elided
    rest, and a list of `"key": value` pairs an object; `as_list`: the JSON values one after the
    other are a list."""
    text = re.sub(r"\{\s*…[^{}]*?…?\s*\}", '"…"', body)
    text = text.replace("{…}", '"…"')
    text = re.sub(r",\s*…\s*(?=})", ', "…": "…"', text)
    if as_list:
        values, pos, decoder = [], 0, json.JSONDecoder()
        while text[pos:].strip():
            pos += len(text[pos:]) - len(text[pos:].lstrip())
            value, pos = decoder.raw_decode(text, pos)
            values.append(value)
        return values
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return json.loads("{" + text + "}")


def fill(part, base):
    """The snippet's value with each `…` replaced by what the file has at the same place."""
    if part == ELLIPSIS:
        assert base is not None, "an elided value (…) where the file has nothing to keep"
        return copy.deepcopy(base)
    if isinstance(part, dict):
        base = base if isinstance(base, dict) else {}
        rest = copy.deepcopy(base) if ELLIPSIS in part else {}
        return {**rest, **{k: fill(v, base.get(k)) for k, v in part.items() if k != ELLIPSIS}}
    if isinstance(part, list):
        return [fill(v, base[i] if isinstance(base, list) and i < len(base) else None) for i, v in enumerate(part)]
    return part


def merge(base, part):
    """The snippet's keys replace the file's (the rest of the file is kept): what a reader who
    pastes the snippet into that object gets."""
    if isinstance(base, dict) and isinstance(part, dict):
        return {**copy.deepcopy(base), **{k: fill(v, base.get(k)) for k, v in part.items()}}
    return fill(part, base)


def put(sweep: dict, at: str, part):
    """The sweep with `part` merged in at the dotted path `at` ('' is the whole file)."""
    if not at:
        return merge(sweep, part)
    out = copy.deepcopy(sweep)
    *parents, last = at.split(".")
    node = out
    for key in parents:
        node = node.setdefault(key, {})
    node[last] = merge(node.get(last), part)
    return out


def json_snippets():
    """Every JSON snippet of the user docs, each with the sweep file it makes (or None, when it is
    checked only with the next one)."""
    out = []
    for doc in DOCS:
        above = None
        pending = None
        for lang, body, line, before in fenced(doc.read_text()):
            if lang != "json":
                continue
            where = f"{doc.relative_to(REPO)}:{line}"
            m = CHECKED.match(before.strip())
            if m is None:
                assert pending is None, f"{where}: the snippet before says it is checked with this one"
                sweep = json.loads(body)
                assert isinstance(sweep, dict) and "base" in sweep, (
                    f"{where}: a snippet that is not a whole sweep file needs a `<!-- checked: into … at … -->` line")
                out.append(pytest.param(sweep, id=where))
                above = sweep
                continue
            into = m.group("into")
            if into == "the snippet above":
                assert above is not None, f"{where}: no snippet above"
                sweep = above
            else:
                sweep = json.loads((REPO / into).read_text())
            if m.group("alone"):
                sweep = {k: v for k, v in sweep.items() if k not in ("axes", "continuation")}
                sweep["axes"] = [{"field": "duration_s", "values": [sweep["base"]["duration_s"]]}]
            try:
                sweep = put(sweep, m.group("at") or "", parse_fragment(body, bool(m.group("lines"))))
            except (ValueError, AssertionError) as e:
                raise AssertionError(f"{where}: {e}") from e
            above = sweep
            if m.group("next"):
                pending = where
                continue
            pending = None
            out.append(pytest.param(sweep, id=where))
        assert pending is None, f"{pending}: no next snippet"
    return out


@pytest.mark.parametrize("sweep", json_snippets())
def test_json_snippet_is_a_valid_sweep(sweep, tmp_path):
    # Beside a copy of the example sweeps: the data files a snippet names are found as they are
    # for the examples.
    folder = tmp_path / "examples"
    shutil.copytree(REPO / "sweeps" / "examples", folder)
    path = folder / "snippet.json"
    path.write_text(json.dumps(sweep, indent=1))
    r = subprocess.run([str(BIN), "validate", str(path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr


# ------------------------------------------------------------------------------------------------
# Commands shown with their output.

NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def shown_commands():
    """Each `$ command` of a sh or text block with the lines shown after it."""
    out = []
    for doc in DOCS:
        for lang, body, line, _ in fenced(doc.read_text()):
            if lang not in ("sh", "text"):
                continue
            lines = body.splitlines()
            for i, text in enumerate(lines):
                if not text.startswith("$ "):
                    continue
                shown = []
                for follow in lines[i + 1:]:
                    if follow.startswith("$ "):
                        break
                    shown.append(follow)
                out.append(pytest.param(text[2:], shown, id=f"{doc.relative_to(REPO)}:{line + 1 + i}"))
    return out


def matches(shown: str, got: str) -> bool:
    """The shown line against the printed one: `…` is any text, numbers agree to 6 significant
    digits, everything else exactly."""
    pattern = ""
    pos = 0
    numbers = []
    for m in re.finditer(rf"{NUMBER.pattern}|{ELLIPSIS}", shown):
        pattern += re.escape(shown[pos:m.start()])
        if m.group() == ELLIPSIS:
            pattern += ".*?"
        else:
            pattern += f"({NUMBER.pattern})"
            numbers.append(m.group())
        pos = m.end()
    pattern += re.escape(shown[pos:])
    found = re.fullmatch(pattern, got)
    if found is None:
        return False
    for want, have in zip(numbers, found.groups()):
        if want != have and not abs(float(want) - float(have)) <= 5e-6 * max(abs(float(want)), 1e-300):
            return False
    return True


@pytest.mark.parametrize("command,shown", shown_commands())
def test_shown_output_is_what_the_command_prints(command, shown, tmp_path):
    argv = shlex.split(command)
    assert argv[0] == "chainsweep", f"a shown command runs chainsweep: {command}"
    # In a copy of the repository's sweeps, so that results/ of the tree is not touched.
    shutil.copytree(REPO / "sweeps", tmp_path / "sweeps")
    (tmp_path / "results").mkdir()
    r = subprocess.run([str(BIN), *argv[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    printed = [line for line in (r.stdout + r.stderr).splitlines() if line.strip()]
    want = [line for line in shown if line.strip()]
    # Every shown line is printed, in order (the command may print more: progress, paths).
    k = 0
    for line in printed:
        if k < len(want) and matches(want[k], line):
            k += 1
    assert k == len(want), (f"shown line not printed: {want[k]!r}\nprinted:\n" + "\n".join(printed))


def test_the_output_check_can_fail():
    assert matches("converged after 22 run(s): x = 6.06518 ± 0.356", "converged after 22 run(s): x = 6.065181 ± 0.356")
    assert not matches("converged after 22 run(s)", "converged after 23 run(s)")
    assert not matches("x = 6.06518", "x = 6.06528")
    assert matches("took … s", "took 0.31 s")
    assert not matches("ended by budget", "ended by tolerance")


# ------------------------------------------------------------------------------------------------
# Python snippets, run verbatim where a comment says what makes the files they read:
#
#     <!-- checked: after chainsweep run sweeps/examples/colliding-waves.json -o colliding-waves.h5 -->
#
# (commands joined by ` && `, run in a folder holding a copy of sweeps/ and an empty results/).
# Every figure a snippet leaves open or saves is drawn and its labels checked: no dotted field
# path, no file bookkeeping (`probe_units`, `…_strlen`) and no text past the figure's edges.

AFTER = re.compile(r"<!-- checked: after (?P<commands>.+) -->")
HARNESS = r'''
import json, re, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

snippet = open(sys.argv[1]).read()
saved = []
original = matplotlib.figure.Figure.savefig
def savefig(self, *args, **kwargs):
    saved.append(self)
    return original(self, *args, **kwargs)
matplotlib.figure.Figure.savefig = savefig
exec(compile(snippet, "snippet", "exec"), {"__name__": "__main__"})
figures = {id(f): f for f in saved}
figures.update({id(plt.figure(n)): plt.figure(n) for n in plt.get_fignums()})
problems = []
labels = []
sys.path.insert(0, sys.argv[2])
import chainplot  # the shipped figures' own check of texts past the edges
for fig in figures.values():
    for ax in fig.axes:
        for what, text in (("x label", ax.xaxis.label), ("y label", ax.yaxis.label), ("title", ax.title)):
            s = text.get_text()
            labels.append([what, s])
            if re.search(r"[a-z_]+\.[a-z_]+\.[a-z_]", s) or "probe_units" in s or "_strlen" in s:
                problems.append(f"{what} {s!r} names the file's bookkeeping or a dotted path")
    problems += [f"{s!r} reaches past the figure's edge" for s in chainplot.texts_outside(fig)]
print(json.dumps({"figures": len(figures), "problems": problems, "labels": labels}))
'''


def python_snippets():
    out = []
    for doc in DOCS:
        for lang, body, line, before in fenced(doc.read_text()):
            m = AFTER.match(before.strip())
            if lang == "python" and m:
                out.append(pytest.param(m.group("commands"), body, id=f"{doc.relative_to(REPO)}:{line}"))
    return out


@pytest.mark.parametrize("commands,snippet", python_snippets())
def test_python_snippet_runs_and_its_figures_are_labelled(commands, snippet, tmp_path):
    import json as _json
    import os
    import sys
    shutil.copytree(REPO / "sweeps", tmp_path / "sweeps")
    (tmp_path / "results" / "examples").mkdir(parents=True)
    for command in commands.split(" && "):
        argv = shlex.split(command.strip().strip("`"))
        assert argv[0] == "chainsweep", command
        r = subprocess.run([str(BIN), *argv[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, (command, r.stderr)
    (tmp_path / "snippet.py").write_text(snippet)
    (tmp_path / "harness.py").write_text(HARNESS)
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "harness.py", "snippet.py", str(REPO / "scripts")], cwd=tmp_path, capture_output=True,
                       text=True, timeout=600, env=env)
    assert r.returncode == 0, r.stderr[-3000:]
    report = _json.loads(r.stdout.strip().splitlines()[-1])
    assert report["problems"] == [], report


def test_the_plotting_snippets_are_checked():
    """The guides' plots are among the snippets run (a lost comment would drop them silently)."""
    checked = " ".join(p.values[1] for p in python_snippets())
    for call in ("m.plot(", "energy_passed_max_j", "plot.line(", "chainsweep.plot("):
        assert call in checked, call
