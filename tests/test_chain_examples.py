"""The delta-force dimer example of sweeps/examples/ (docs/CHAINS.md) end to end: the sweep file as
shipped, run by the binary into HDF5, drawn by scripts/examples.py, and the physics of its
attenuation table: at mass ratio 1 every mass and contact is equal, so the chain is monodisperse
and carries the leading pulse as a solitary wave, unchanged; near eps = 0.575 the dimer attenuates
it most; damping attenuates at every mass ratio."""

import os
import subprocess
import sys

import numpy as np

from conftest import REPO, run

SCRIPTS = REPO / "scripts"


def test_dimer_example_runs_draws_and_attenuates(binary, tmp_path):
    out = tmp_path / "examples" / "dimer-impulse.h5"
    out.parent.mkdir()
    r = run("run", REPO / "sweeps" / "examples" / "dimer-impulse.json", "-o", out, "--jobs", "2", "--quiet")
    assert r.returncode == 0, r.stderr

    env = dict(os.environ, CHAINSWEEP_RESULTS=str(tmp_path))
    p = subprocess.run(
        [sys.executable, "examples.py", "dimer-impulse"], cwd=SCRIPTS, env=env, capture_output=True, text=True
    )
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "examples" / "dimer-impulse.png").stat().st_size > 10_000

    sys.path.insert(0, str(SCRIPTS))
    try:
        import examples
        from chainplot import Sweep
    finally:
        sys.path.remove(str(SCRIPTS))
    with Sweep(out) as sw:
        assert (sw.status == 1).all(), sw.failures()
        eps, att = examples.dimer_attenuation(sw)
    undamped, damped = att[0.0], att[5.0]
    assert abs(eps[-1] - 1.0) < 1e-9
    assert abs(undamped[-1] - 1.0) < 1e-3, undamped[-1]
    i_min = int(np.argmin(undamped))
    assert abs(eps[i_min] - 0.575) < 0.03, eps[i_min]
    assert undamped[i_min] < 0.45, undamped[i_min]
    assert (damped < undamped).all()
    # The printed table is the one docs/CHAINS.md quotes.
    docs = (REPO / "docs" / "CHAINS.md").read_text()
    for line in p.stdout.splitlines():
        if line.startswith("| 0.575 |") or line.startswith("| 1.000 |"):
            assert line.strip() in docs, line
