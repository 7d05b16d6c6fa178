"""Pin BLAS to one thread for the library's small matrices (unless the user chose a thread count).

The filters multiply 50 x 50 matrices thousands of times per run; OpenBLAS threads spinning on such
sizes cost 2.6-5x on a busy two-core machine (README, "Design notes a maintainer needs"). Called once when ``postcapture`` is imported:
before numpy is loaded the environment variables do it; after, threadpoolctl limits the loaded BLAS.
An explicit ``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS`` or ``MKL_NUM_THREADS`` is left alone.
"""

from __future__ import annotations

import os
import sys

__all__ = ["limit_blas_threads"]

_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def limit_blas_threads() -> None:
    """One BLAS thread, unless one of ``OPENBLAS/OMP/MKL_NUM_THREADS`` is set."""
    if any(v in os.environ for v in _VARS):
        return
    for v in _VARS:
        os.environ[v] = "1"
    if "numpy" in sys.modules:  # already loaded: the variables come too late for its BLAS
        from threadpoolctl import threadpool_limits

        threadpool_limits(1, user_api="blas")
