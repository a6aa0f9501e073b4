"""Process-wide settings a command applies before any work: the CPU threads numerical libraries use,
and how much the command prints (`--quiet`, `--verbose`).

Torch and the BLAS libraries otherwise start one thread per core; on a loaded machine those threads
compete and a planner's wall-clock budget then buys a different amount of search (one `tsad plan`
on the network took 36.8 s instead of 2.4 s), so every command pins them (`--threads`, default 1)
and bench workers do the same.
"""

from __future__ import annotations

import logging
import os
import sys

#: read by OpenMP, MKL, OpenBLAS, numexpr and Drake (its `Parallelism`) when they load
THREAD_ENV_VARS = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                   "NUMEXPR_NUM_THREADS", "DRAKE_NUM_THREADS")


def pin_threads(threads: int) -> None:
    """Use `threads` CPU threads in torch and the BLAS libraries from now on (in this process and
    in processes it starts). The environment reaches libraries loaded later; torch, when already
    loaded, is told directly."""
    for name in THREAD_ENV_VARS:
        os.environ[name] = str(threads)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(threads)


#: --quiet: results and errors only; the default adds progress bars and per-step lines;
#: --verbose adds per-episode lines and Drake's INFO log
QUIET, NORMAL, VERBOSE = 0, 1, 2
#: the verbosity travels to bench workers (and any process a command starts) in the environment
VERBOSITY_ENV = "TSAD_VERBOSITY"


def set_verbosity(level: int) -> None:
    """Print at `level` from now on, in this process and in processes it starts."""
    os.environ[VERBOSITY_ENV] = str(level)
    drake_level = {QUIET: logging.ERROR, NORMAL: logging.WARNING, VERBOSE: logging.INFO}[level]
    logging.getLogger("drake").setLevel(drake_level)


def verbosity() -> int:
    """The level `set_verbosity` set (NORMAL when none was, or the environment holds junk)."""
    value = os.environ.get(VERBOSITY_ENV, "")
    return int(value) if value in ("0", "1", "2") else NORMAL


def show_progress(progress: bool = True) -> bool:
    """Whether a progress bar asked for with `progress` is shown (never under --quiet)."""
    return progress and verbosity() >= NORMAL


def detail(message: str) -> None:
    """A line of detail on stdout (per-step lines): shown unless --quiet."""
    if verbosity() >= NORMAL:
        print(message)


def debug(message: str) -> None:
    """A line for --verbose only, on stderr (stdout stays the command's result)."""
    if verbosity() >= VERBOSE:
        print(message, file=sys.stderr)
