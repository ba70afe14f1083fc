"""A private single-node SLURM cluster on this machine, for tests and for trying the cluster path.

No systemd and no change to /etc beyond what Debian's packages install: munged, slurmctld and
slurmd run from a private folder (sockets, state, logs, pid files, free ports), as root, one node
named after this host with the CPUs of `nproc`. Clients find it through `SLURM_CONF`.

    python scripts/slurm_local.py start DIR     # prints `export SLURM_CONF=DIR/slurm.conf`
    python scripts/slurm_local.py stop DIR

Missing packages are installed from Debian's registry (`slurm-wlm` and `munge`, or `slurmd`,
`slurmctld`, `slurm-client`, whichever the registry has) when running as root. Every failure
raises `SlurmError` saying what went wrong, with the daemons' log tails.
"""

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "squeue", "scancel", "sinfo")


class SlurmError(RuntimeError):
    """SLURM could not be installed, started or stopped; the message says why."""


def _sbin(name):
    return shutil.which(name) or shutil.which(name, path="/usr/sbin:/sbin:/usr/bin")


def _missing():
    return [n for n in DAEMONS + CLIENTS if _sbin(n) is None]


def _apt(*args, timeout=600):
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    r = subprocess.run(["apt-get", *args], capture_output=True, text=True, env=env, timeout=timeout)
    if r.returncode != 0:
        raise SlurmError(f"apt-get {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()[-2000:]}")


def _has_candidate(package):
    r = subprocess.run(["apt-cache", "policy", package], capture_output=True, text=True)
    return r.returncode == 0 and "Candidate:" in r.stdout and "Candidate: (none)" not in r.stdout


def install():
    """Installs SLURM and munge from Debian's packages when a daemon or client is missing."""
    missing = _missing()
    if not missing:
        return
    if os.geteuid() != 0:
        raise SlurmError(f"SLURM is not installed ({', '.join(missing)} missing) and installing needs root")
    if shutil.which("apt-get") is None:
        raise SlurmError(f"SLURM is not installed ({', '.join(missing)} missing) and there is no apt-get")
    _apt("update")
    packages = ["slurm-wlm"] if _has_candidate("slurm-wlm") else ["slurmd", "slurmctld", "slurm-client"]
    _apt("install", "-y", "--no-install-recommends", *packages, "munge")
    still = _missing()
    if still:
        raise SlurmError(f"after installing {packages + ['munge']}: still missing {', '.join(still)}")


def _free_ports(n):
    socks = []
    try:
        for _ in range(n):
            s = socket.socket()
            s.bind(("127.0.0.1", 0))
            socks.append(s)
        return [s.getsockname()[1] for s in socks]
    finally:
        for s in socks:
            s.close()


def _ensure_munge_key():
    key = Path("/etc/munge/munge.key")
    if key.exists():
        return
    mungekey = _sbin("mungekey")
    if mungekey:
        r = subprocess.run(["runuser", "-u", "munge", "--", mungekey, "--create"], capture_output=True, text=True)
        if r.returncode == 0 and key.exists():
            return
    key.parent.mkdir(parents=True, exist_ok=True)
    key.write_bytes(os.urandom(1024))
    shutil.chown(key, "munge", "munge")
    key.chmod(0o400)


def _tail(path, n=20):
    try:
        return "\n".join(Path(path).read_text(errors="replace").splitlines()[-n:])
    except OSError:
        return "(no log)"


def _logs(d):
    return "\n".join(
        f"--- {name} ---\n{_tail(d / name)}"
        for name in ("munge-run/munged.log", "log/slurmctld.log", "log/slurmd.log")
    )


def _conf(d, host, cpus, ports):
    return f"""\
ClusterName=chainsweep-test
SlurmctldHost={host}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={d}/munge-run/munge.socket
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/log/slurmctld.log
SlurmdLogFile={d}/log/slurmd.log
SlurmctldPort={ports[0]}
SlurmdPort={ports[1]}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
ReturnToService=2
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
KillWait=5
NodeName={host} CPUs={cpus} State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
"""


def env_of(d):
    """The environment of SLURM's clients for the cluster in `d`."""
    return dict(os.environ, SLURM_CONF=str(Path(d) / "slurm.conf"))


def start(d, timeout=60):
    """Installs SLURM if needed and starts munged, slurmctld and slurmd in folder `d` (created);
    returns the clients' environment once the node is idle."""
    if os.geteuid() != 0:
        raise SlurmError("the private SLURM cluster runs its daemons as root; this is not root")
    install()
    _ensure_munge_key()
    d = Path(d).resolve()
    for sub in ("state", "spool", "log", "munge-run"):
        (d / sub).mkdir(parents=True, exist_ok=True)
    d.chmod(0o755)
    shutil.chown(d / "munge-run", "munge", "munge")
    # One node named as slurmd finds itself (`hostname -s`), with every CPU of `nproc`.
    host = socket.gethostname().split(".")[0]
    cpus = os.cpu_count() or 1
    (d / "slurm.conf").write_text(_conf(d, host, cpus, _free_ports(2)))
    run_dir = d / "munge-run"
    r = subprocess.run(
        ["runuser", "-u", "munge", "--", _sbin("munged"), f"--socket={run_dir}/munge.socket",
         f"--pid-file={run_dir}/munged.pid", f"--log-file={run_dir}/munged.log",
         f"--seed-file={run_dir}/munged.seed"],
        capture_output=True, text=True,
    )
    if r.returncode != 0:
        raise SlurmError(f"munged did not start ({r.returncode}): {r.stderr.strip()}\n{_logs(d)}")
    for daemon in ("slurmctld", "slurmd"):
        r = subprocess.run([_sbin(daemon), "-f", str(d / "slurm.conf")], capture_output=True, text=True)
        if r.returncode != 0:
            stop(d)
            raise SlurmError(f"{daemon} did not start ({r.returncode}): {r.stderr.strip()}\n{_logs(d)}")
    env = env_of(d)
    deadline = time.time() + timeout
    state = ""
    while time.time() < deadline:
        r = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True, env=env)
        state = (r.stdout + r.stderr).strip()
        if r.returncode == 0 and state.startswith("idle"):
            return env
        time.sleep(0.3)
    stop(d)
    raise SlurmError(f"the node did not become idle within {timeout} s (sinfo: {state!r})\n{_logs(d)}")


def _pid(path):
    try:
        return int(Path(path).read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def stop(d, timeout=20):
    """Stops the daemons started in `d`, by the pids in their pid files (slurmd, slurmctld,
    munged); returns the pids it stopped."""
    d = Path(d)
    stopped = []
    for pidfile in (d / "slurmd.pid", d / "slurmctld.pid", d / "munge-run" / "munged.pid"):
        pid = _pid(pidfile)
        if pid is None:
            continue
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            continue
        deadline = time.time() + timeout
        while time.time() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.1)
        else:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        stopped.append(pid)
    return stopped


def main(argv):
    if len(argv) != 3 or argv[1] not in ("start", "stop"):
        print(__doc__)
        return 2
    if argv[1] == "start":
        env = start(argv[2])
        print(f"export SLURM_CONF={env['SLURM_CONF']}")
    else:
        print("stopped:", " ".join(map(str, stop(argv[2]))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
