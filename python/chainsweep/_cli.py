"""The ``chainsweep`` command installed with the package (a console script) and
``python -m chainsweep``: the runner's own command line, run by the engine in this process, so
that ``chainsweep run``, ``status``, ``merge``, ``slurm``, … behave exactly as the native binary
does (the same options, output, exit codes, Ctrl-C and SIGTERM handling)."""

from __future__ import annotations

import os
import shutil
import signal
import sys


def _this_command() -> str | None:
    """The path of the ``chainsweep`` command this process runs as: the console script itself,
    or for ``python -m chainsweep`` the one installed beside the interpreter."""
    script = sys.argv[0] if sys.argv else ""
    if os.path.basename(script) == "chainsweep" and os.path.isfile(script):
        return os.path.abspath(script)
    beside = os.path.join(os.path.dirname(sys.executable), "chainsweep")
    if os.path.isfile(beside) and os.access(beside, os.X_OK):
        return beside
    return shutil.which("chainsweep")


def main(argv: list[str] | None = None) -> None:
    """Runs ``chainsweep`` with ``argv`` (default: this process's arguments) and exits with its
    code."""
    args = sys.argv[1:] if argv is None else list(argv)
    # `chainsweep run` handles SIGINT as the binary does (a first Ctrl-C stops the sweep with its
    # output written, exit 130; a second ends the process at once), on top of the handler it
    # finds installed, which it calls too: Python's would then raise KeyboardInterrupt once the
    # command is done. The default action is restored first, as the binary starts with it.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    # The job scripts of `chainsweep slurm` run the command again: this one, not the interpreter
    # the engine finds itself running in.
    command = _this_command()
    if command:
        os.environ.setdefault("CHAINSWEEP_EXE", command)
    from ._chainsweep import cli_main

    sys.exit(cli_main(["chainsweep", *args]))
