"""CPU thread policy: degrade gracefully when the cores are shared.

PyTorch's CPU build runs its kernels on an OpenMP pool with one thread per core. When
another busy process shares the cores, OpenMP threads that *spin* while waiting at a barrier
burn the time the other process needs, and two trainings at once can fall from several
steps per second to seconds per step. Two settings avoid that:

* ``OMP_WAIT_POLICY=PASSIVE``: idle OpenMP threads sleep instead of spinning. It must be set
  before torch loads its OpenMP runtime, so :func:`configure` runs before any torch import
  in the CLI, and ``import scdp`` sets it as a default too.
* ``threads``: the size of the pool (``--threads N`` on the command line). By default the
  pool keeps torch's own choice, or ``OMP_NUM_THREADS`` when the user set it.

A user's own ``OMP_WAIT_POLICY`` is never overridden.

Sleeping has a price where the work is many tiny kernels: batch-1 planning with the cpu
preset took 130 ms per chunk with two sleeping threads, 34 ms with two spinning ones and 35 ms
with one thread (``results/benchmarks/thread_contention.md``). One thread has no team to wake
and cannot oversubscribe the cores, so :func:`use_for_planning` gives latency-bound callers
(``scdp plan``, ``scdp serve``) a single thread unless the user chose a count, or unless the
network is large (:data:`LARGE_NETWORK`): at the paper's size a batch-1 network call does
enough work per kernel that every core pays (``results/benchmarks/plan_latency.md``).
"""

from __future__ import annotations

import os
import sys

from scdp.errors import ScdpError


def configure(threads: int | None = None) -> None:
    """Set the wait policy (unless the user chose one) and, if given, the number of threads.
    Call it before torch is imported when possible; the thread count also applies afterwards."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    if threads is None:
        return
    if threads < 1:
        raise ScdpError("--threads", f"must be >= 1, got {threads}")
    os.environ["OMP_NUM_THREADS"] = str(threads)
    os.environ["MKL_NUM_THREADS"] = str(threads)
    if "torch" in sys.modules:  # already loaded: resize its pool directly
        sys.modules["torch"].set_num_threads(threads)


PLANNING_THREADS = 1
LARGE_NETWORK = 10_000_000  # parameters of a denoising network from which batch-1 planning uses every core


def cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def planning_threads(parameters: int = 0) -> int:
    """The thread count for batch-1 planning of a denoising network of ``parameters``: the user's count
    (``--threads`` or ``OMP_NUM_THREADS``) if given; else every core for a network of at least
    :data:`LARGE_NETWORK` parameters, and :data:`PLANNING_THREADS` for a smaller one."""
    chosen = os.environ.get("OMP_NUM_THREADS", "")
    if chosen.isdigit() and int(chosen) > 0:
        return int(chosen)
    return cores() if parameters >= LARGE_NETWORK else PLANNING_THREADS


def use_for_planning(parameters: int = 0) -> int:
    """Size torch's pool for batch-1 planning on the calling thread (:func:`planning_threads`).
    Returns the count."""
    count = planning_threads(parameters)
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(count)
    return count
