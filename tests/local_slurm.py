"""A one-node SLURM cluster on localhost for tests: munged, slurmctld and slurmd in a temporary directory.

Needs Debian's ``slurm-wlm`` and ``munge`` and root (the daemons run as root). Everything
(configuration, keys, sockets, state, logs) lives under one directory, so nothing of the
machine's own SLURM or munge set-up is read or changed; every daemon is stopped on exit,
also when the body of the ``with`` fails.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

DAEMONS = ("munged", "mungekey", "slurmctld", "slurmd", "sbatch", "srun", "squeue", "sinfo")


def missing_prerequisites() -> str | None:
    """Why a local cluster cannot start here, or None."""
    missing = [name for name in DAEMONS if shutil.which(name) is None and not Path(f"/usr/sbin/{name}").exists()]
    if missing:
        return f"{', '.join(missing)} not installed (Debian: apt-get install slurm-wlm munge)"
    if os.geteuid() != 0:
        return "the SLURM daemons of the local test cluster run as root"
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _memory_mb() -> int:
    """RealMemory of the node: 90 % of this machine's memory (slurmd drains a node that claims more)."""
    total_kb = int(
        next(line for line in Path("/proc/meminfo").read_text().splitlines() if line.startswith("MemTotal")).split()[1]
    )
    return int(total_kb / 1024 * 0.9)


def slurm_conf(directory: Path, cpus: int, memory_mb: int) -> str:
    """A minimal slurm.conf: one node 'localhost', one default partition, state and logs in ``directory``."""
    return f"""\
ClusterName=costa-test
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
SlurmctldPort={_free_port()}
SlurmdPort={_free_port()}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={directory}/munge.socket
StateSaveLocation={directory}/state
SlurmdSpoolDir={directory}/spool
SlurmctldPidFile={directory}/slurmctld.pid
SlurmdPidFile={directory}/slurmd.pid
SlurmctldLogFile={directory}/slurmctld.log
SlurmdLogFile={directory}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
MinJobAge=600
SlurmdTimeout=60
NodeName=localhost NodeHostname=localhost NodeAddr=127.0.0.1 CPUs={cpus} RealMemory={memory_mb} State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
"""


def _wait_for(check, what: str, seconds: float, logs: list[Path]) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if check():
            return
        time.sleep(0.2)
    tails = "\n".join(f"--- {p}\n{p.read_text()[-2000:]}" for p in logs if p.exists())
    raise RuntimeError(f"local SLURM: {what} not ready after {seconds} s\n{tails}")


@contextlib.contextmanager
def local_slurm(directory: Path, cpus: int = 2) -> Iterator[dict[str, str]]:
    """Start munged, slurmctld and slurmd; yield the environment that points SLURM's commands at them."""
    directory.mkdir(parents=True, exist_ok=True)
    for sub in ("state", "spool"):
        (directory / sub).mkdir(exist_ok=True)
    conf = directory / "slurm.conf"
    conf.write_text(slurm_conf(directory, cpus, _memory_mb()))
    # SLURM's commands find this cluster through SLURM_CONF. The executor plugin's job step
    # drops every SLURM_* variable before its inner srun (a real cluster has
    # /etc/slurm/slurm.conf), so an srun first on PATH sets it again.
    wrappers = directory / "bin"
    wrappers.mkdir(exist_ok=True)
    srun = wrappers / "srun"
    srun.write_text(f'#!/bin/sh\nSLURM_CONF={conf} exec {shutil.which("srun")} "$@"\n')
    srun.chmod(0o755)
    env = {**os.environ, "SLURM_CONF": str(conf), "PATH": f"{wrappers}{os.pathsep}{os.environ['PATH']}"}
    key = directory / "munge.key"
    subprocess.run(["mungekey", "--create", f"--keyfile={key}", "--force"], check=True, capture_output=True)
    key.chmod(0o600)
    processes: list[subprocess.Popen] = []
    logs = [directory / "munged.log", directory / "slurmctld.log", directory / "slurmd.log"]
    try:
        processes.append(subprocess.Popen([
            "munged", "--foreground", "--force", f"--socket={directory}/munge.socket", f"--key-file={key}",
            f"--pid-file={directory}/munged.pid", f"--log-file={directory}/munged.log",
            f"--seed-file={directory}/munged.seed",
        ], stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))  # fmt: skip
        _wait_for(lambda: (directory / "munge.socket").exists(), "munged", 20, logs)
        processes.append(subprocess.Popen(["slurmctld", "-D", "-i", "-f", str(conf)], env=env,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))  # fmt: skip
        processes.append(subprocess.Popen(["slurmd", "-D", "-f", str(conf)], env=env,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT))  # fmt: skip

        def node_idle() -> bool:
            result = subprocess.run(["sinfo", "-h", "-N", "-o", "%t"], env=env, capture_output=True, text=True)
            return result.returncode == 0 and result.stdout.strip() in ("idle", "mix", "alloc")

        _wait_for(node_idle, "node localhost", 60, logs)
        yield env
    finally:
        for process in reversed(processes):
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for process in reversed(processes):
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
