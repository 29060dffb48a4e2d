"""The CPU kernels a job runs: pinned so that its numbers do not depend on the CPU.

torch's own kernels dispatch on the CPU's vector ISA (``ATEN_CPU_CAPABILITY``; it also
sets torch.compile's vector width) and oneMKL, which does torch's float matrix products,
picks a code branch per CPU (``MKL_CBWR``).  Different branches round differently, so
the same training gives different networks on different CPUs.  Both variables are read
when a process first uses them: the workflow sets them before any job starts.
"""

from __future__ import annotations

import os
import platform
from collections.abc import Mapping
from pathlib import Path

__all__ = ["cpu_model", "kernel_environment", "kernel_provenance"]

VARIABLES = {"aten_isa": "ATEN_CPU_CAPABILITY", "mkl_branch": "MKL_CBWR"}


def kernel_environment(kernels: Mapping[str, str | None]) -> dict[str, str]:
    """The environment variables that pin the kernels of config ``kernels`` (a null value sets nothing)."""
    return {variable: str(kernels[key]) for key, variable in VARIABLES.items() if kernels.get(key) is not None}


def cpu_model() -> str:
    """The CPU's model name as the operating system reports it."""
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def kernel_provenance() -> dict[str, str]:
    """What decides this process's floating-point results: torch, the CPU and the kernels in use."""
    import torch

    return {
        "torch": torch.__version__,
        "CPU": cpu_model(),
        "torch kernel ISA": torch.backends.cpu.get_cpu_capability(),
        "oneMKL branch (MKL_CBWR)": os.environ.get("MKL_CBWR", "the CPU's own (unset)"),
    }
