"""The CPU kernels: training is finite and the same under every kernel ISA, and bit for bit
the same on every machine where the workflow pins the kernels (config ``kernels``)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import REPOSITORY

from costa.config import load_config
from costa.kernels import kernel_environment

SCRIPT = REPOSITORY / "tests" / "kernel_training.py"
# sha256 of the smoke config's four trained ensembles under the default config's kernels
# (ATEN_CPU_CAPABILITY=avx2, MKL_CBWR=AVX2); a machine that trains other weights breaks
# the claim that the numbers do not depend on the CPU.
SMOKE_WEIGHTS_SHA256 = "3c90a28da679883bbaea097ab5da8c5956a03aac8979665fced30ee156d51a20"


def train(*args: str, **environment: str) -> dict:
    """Run tests/kernel_training.py in a fresh process with ``environment`` added."""
    inherited = {k: v for k, v in os.environ.items() if k not in ("ATEN_CPU_CAPABILITY", "MKL_CBWR")}
    env = {**inherited, "OMP_NUM_THREADS": "1", **environment}
    done = subprocess.run(
        [sys.executable, str(SCRIPT), *args], env=env, cwd=REPOSITORY, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_the_default_kernels_are_avx2_in_torch_and_onemkl():
    assert kernel_environment(load_config()["kernels"]) == {"ATEN_CPU_CAPABILITY": "avx2", "MKL_CBWR": "AVX2"}
    assert kernel_environment({"aten_isa": None, "mkl_branch": None}) == {}


def _cpu_vendor() -> str:
    """The CPU's vendor id (GenuineIntel, AuthenticAMD), or '' where /proc/cpuinfo does not say."""
    try:
        lines = open("/proc/cpuinfo").read().splitlines()
    except OSError:
        return ""
    return next((line.split(":")[1].strip() for line in lines if line.startswith("vendor_id")), "")


@pytest.mark.skipif(_cpu_vendor() != "GenuineIntel", reason="oneMKL's reproducible AVX2 branch runs on Intel CPUs only")
def test_the_smoke_ensembles_weights_hash_to_the_committed_value():
    """The claim 'same config and seed, same numbers on any Intel CPU with AVX2': every
    Intel machine that runs this test checks it."""
    result = train("smoke", **kernel_environment(load_config()["kernels"]))
    assert result["oneMKL branch (MKL_CBWR)"] == "AVX2"
    assert result["hash"] == SMOKE_WEIGHTS_SHA256, f"other weights on {result['CPU']} ({result['torch kernel ISA']})"


@pytest.mark.skipif(_cpu_vendor() == "GenuineIntel", reason="on Intel CPUs the pin selects oneMKL's AVX2 branch")
def test_elsewhere_the_onemkl_pin_falls_back_to_the_cpus_own_branch():
    """What docs/reproducibility.md says of other CPUs: oneMKL's MKL_CBWR=AVX2 is its own branch
    there (AUTO), so the weights are this CPU's, not the committed Intel ones (measured on an
    AMD EPYC, Zen 4: AVX2, AVX512 and AUTO gave the same weights, other than Intel's)."""
    pinned = kernel_environment(load_config()["kernels"])
    result, own = train("smoke", **pinned), train("smoke", **{**pinned, "MKL_CBWR": "AUTO"})
    assert result["hash"] == own["hash"]


@pytest.mark.integration
def test_training_is_finite_and_the_same_under_avx2_and_the_default_isa_compiled_and_eager(tmp_path):
    """Compiled under the CPU's own ISA first, then under AVX2 from the same compile cache:
    torch 2.13 served the first ISA's kernels to the second, whose losses turned NaN."""
    cache = {"TORCHINDUCTOR_CACHE_DIR": str(tmp_path / "inductor")}
    runs = {
        (isa, mode): train("small", mode, **cache, **({"ATEN_CPU_CAPABILITY": isa} if isa else {}))
        for isa in (None, "avx2")
        for mode in ("compiled", "eager")
    }
    for (_, mode), run in runs.items():
        assert np.isfinite(run["mse"]).all(), f"{mode} under {run['torch kernel ISA']}: {run['mse']}"
    reference = runs[(None, "eager")]["mse"]
    for run in runs.values():
        np.testing.assert_allclose(run["mse"], reference, rtol=1e-4)
