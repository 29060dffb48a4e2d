"""What every workflow script does first: log to its log file, respect its threads."""

from __future__ import annotations

import logging
import os
import sys
from typing import Any

THREAD_VARIABLES = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def configure(snakemake: Any) -> logging.Logger:
    """Send logging and uncaught errors to the job's log; use only the job's threads.

    torch ignores Snakemake's ``threads:``; two jobs with all cores each
    oversubscribe a small machine by 6-14x (measured on 2 cores), so the thread count is
    set explicitly: in torch if a job has imported it, else in the environment it reads
    when it is first imported (jobs without networks never import it, 2-3 s each).
    """
    threads = max(1, int(snakemake.threads))
    for variable in THREAD_VARIABLES:
        os.environ[variable] = str(threads)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(threads)
    logging.basicConfig(
        filename=snakemake.log[0] if snakemake.log else None,
        level=logging.INFO,
        format="%(asctime)s %(levelname)s %(message)s",
        force=True,
    )
    log = logging.getLogger(snakemake.rule)

    def log_uncaught(kind, value, traceback):
        log.error("failed", exc_info=(kind, value, traceback))
        sys.__excepthook__(kind, value, traceback)

    sys.excepthook = log_uncaught
    log.info("rule %s, %d thread(s), wildcards %s", snakemake.rule, threads, dict(snakemake.wildcards))
    return log
