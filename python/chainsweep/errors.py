"""The exceptions of the chainsweep package.

- :class:`InputError` (a ``ValueError``): bad input — a scene, a sweep or an argument — with the
  dotted path of the offending field in ``.field``; nothing was run, created or modified.
- :class:`RunError` (a ``RuntimeError``): a scene ran and failed (panic, NaN, step budget, step
  size collapse, energy drift over the limit); ``.reason`` says why and ``.result`` holds what the
  run recorded (status, reason, wall time; NaN elsewhere).
- :class:`SweepError` (a ``RuntimeError``): a sweep could not go on for a reason other than its
  input (I/O, HDF5, the output locked by another process): the command line's exit code 1.
- :class:`DamagedFileError` (an ``OSError``): a result file whose stored values do not match
  their checksums; ``.damaged`` lists the damaged points as ``(flat index, axis values, why)``.

All four derive from :class:`Error`.
"""

from __future__ import annotations

import re
from typing import Any

__all__ = ["Error", "InputError", "RunError", "SweepError", "DamagedFileError", "from_runner"]


class Error(Exception):
    """Base class of the package's exceptions."""


class InputError(Error, ValueError):
    """Bad input: ``field`` is the dotted path of the offending field (``""`` for the whole input).

    Paths are those of the input the function took: for :func:`chainsweep.run` a scene field
    (``chain.cylinders``, ``record.probes[0].cylinder``, ``limits.energy_drift_max``); for
    :func:`chainsweep.sweep` a sweep-file field (``base.duration_s``, ``axes[0].values[3]``) or an
    argument name (``jobs``, ``shard``, ``verify``, ``output``).
    """

    def __init__(self, field: str, message: str):
        self.field = field
        self.message = message
        super().__init__(f"field `{field}`: {message}" if field else message)


class RunError(Error, RuntimeError):
    """A run that failed: ``reason`` says why; ``result`` is what it recorded (a Dataset, or a dict
    with ``as_dataset=False``) with ``status`` 2 and NaN summaries."""

    def __init__(self, reason: str, result: Any = None):
        self.reason = reason
        self.result = result
        super().__init__(f"the run failed: {reason}")


class SweepError(Error, RuntimeError):
    """A sweep stopped by something other than its input (I/O, HDF5, a locked output)."""


class DamagedFileError(Error, OSError):
    """A result file that cannot be served as it stands: ``path``; ``damaged`` holds the damaged
    points as ``(flat index, axis values, why)`` (empty when the whole file, its header or its
    coordinates are damaged). ``chainsweep run`` of its sweep into the same file repairs it (runs
    restored from the snapshot in its work directory are kept, the others computed again);
    ``chainsweep.open(path, damaged="mask")`` serves the intact points, the damaged ones masked."""

    def __init__(self, path: str, message: str, damaged: list[tuple[int, str, str]]):
        self.path = path
        self.damaged = damaged
        super().__init__(message)


# The command line's option names as the arguments of chainsweep.sweep.
_OPTION_ARGUMENTS = {
    "--output": "output",
    "--jobs": "jobs",
    "--shard": "shard",
    "--ensemble-round": "ensemble_round",
    "--verify": "verify",
    "--checkpoint-interval": "checkpoint_interval",
}

_MISSING = re.compile(r"missing field `([^`]+)`")


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def from_runner(kind: str, field: str, message: str, context: str) -> Error:
    """The exception for a runner error (called by the native module).

    ``kind`` is ``"input"`` or ``"other"``; ``context`` is ``"scene"`` (chainsweep.run: the scene
    was the ``base`` of a one-point sweep, so ``base.`` is dropped from field paths) or
    ``"sweep"`` (chainsweep.sweep: command-line options are named as the function's arguments).
    """
    if kind != "input":
        return RunError(message) if context == "scene" else SweepError(message)
    if context == "scene":
        if field == "base":
            field = ""
        elif field.startswith("base."):
            field = field[len("base."):]
    else:
        field = _OPTION_ARGUMENTS.get(field, field)
    missing = _MISSING.search(message)
    if missing:
        field = _join(field, missing.group(1))
    return InputError(field, message)
