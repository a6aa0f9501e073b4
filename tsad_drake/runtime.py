"""Process-wide settings a command applies before any work: the CPU threads numerical libraries use.

Torch and the BLAS libraries otherwise start one thread per core; on a loaded machine those threads
compete and a planner's wall-clock budget then buys a different amount of search (one `tsad plan`
on the network took 36.8 s instead of 2.4 s), so every command pins them (`--threads`, default 1)
and bench workers do the same.
"""

from __future__ import annotations

import os
import sys

#: read by OpenMP, MKL, OpenBLAS and numexpr when they load
THREAD_ENV_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                   "NUMEXPR_NUM_THREADS")


def pin_threads(threads: int) -> None:
    """Use `threads` CPU threads in torch and the BLAS libraries from now on (in this process and
    in processes it starts). The environment reaches libraries loaded later; torch, when already
    loaded, is told directly."""
    for name in THREAD_ENV_VARS:
        os.environ[name] = str(threads)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(threads)
