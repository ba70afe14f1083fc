"""Scenes and sweeps for the Python package's tests (small and fast: 10 cylinders, 0.2 ms)."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

from conftest import base_sweep

REPO = Path(__file__).resolve().parents[2]


def sweep_spec(**kw) -> dict:
    """The shared test sweep (tests/conftest.py): 3 mass ratios x 2 dampings, gauges 2 and 8."""
    return base_sweep(**kw)


def scene(**kw) -> dict:
    """The base scene of the test sweep with its record block inside."""
    s = sweep_spec(**kw)
    out = copy.deepcopy(s["base"])
    out["record"] = s["record"]
    return out


def set_path(root: dict, path: str, value) -> None:
    """Sets the field at dotted `path` (`a.b[2].c`) of `root`."""
    keys = [int(k) if k.isdigit() else k for k in re.findall(r"[^.\[\]]+", path)]
    for k in keys[:-1]:
        root = root[k]
    root[keys[-1]] = value


def point_scene(spec: dict, index: int) -> dict:
    """The base scene of sweep `spec` at grid point `index` (row-major), axis values applied."""
    shape = [len(a["values"]) for a in spec["axes"]]
    out = copy.deepcopy(spec["base"])
    rest = index
    for axis, n in reversed(list(zip(spec["axes"], shape))):
        set_path(out, axis["field"], axis["values"][rest % n])
        rest //= n
    return out


def write(path: Path, spec: dict) -> Path:
    path.write_text(json.dumps(spec, indent=2))
    return path
