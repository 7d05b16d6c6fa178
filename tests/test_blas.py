"""BLAS is pinned to one thread by the library itself, unless the user chose a thread count."""

import os
import subprocess
import sys

CODE = """
import numpy, postcapture
from threadpoolctl import threadpool_info
print(max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"))
"""


def _threads(env_extra):
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    env.update(env_extra)
    out = subprocess.run([sys.executable, "-c", CODE], env=env, capture_output=True, text=True, check=True)
    return int(out.stdout.strip())


def test_one_blas_thread_after_import():
    assert _threads({}) == 1


def test_an_explicit_thread_count_is_kept():
    assert _threads({"OPENBLAS_NUM_THREADS": "2"}) == 2
