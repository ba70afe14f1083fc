"""``python -m chainsweep …``: the ``chainsweep`` command (see ``chainsweep --help``)."""

from ._cli import main

main()
