"""Where independent runs go: one after another in this process (``local``, the default), or as Ray
tasks over the machines of a cluster (``ray``, ``pip install 'scdp[cluster]'``).

A :class:`Unit` is one independent run: a training seed's model set, a per-layout model set, a
sweep point, a task. It is a module-level function (what a worker calls) with its arguments, a label,
the number of steps it reports, and what it needs (CPUs, GPUs). An executor runs a list of units and
returns their results in order, showing one progress bar per unit.

Units write through scdp's content-keyed stages into a folder every worker shares (the run's
``--out``), so a rerun after a failure or a lost machine redoes only what is not current, and each
stage's lock (:meth:`scdp.pipeline.stages.Stage.run`) keeps two workers off one output. A Ray task
whose worker dies is retried (``retries`` times) on another worker; the retry finds the stages its
predecessor finished up to date and goes on from there. A unit that fails outright cancels the
units not yet finished and stops the run with its error: run the command again to resume.

A unit function takes its arguments and ``report``, a callable given the number of steps done so far.
Ray is imported by name (the floor plan's fifth such place) only when asked for, so ``local`` runs
never load it.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import torch
from tqdm.auto import tqdm

from scdp import threads
from scdp.errors import ScdpError
from scdp.keys import EXECUTORS, LOCAL, RAY

WORKER_RETRIES = 2  # a Ray task whose worker died runs again this many times before the run fails


def local_threads() -> int:
    """The threads a local run computes with (``scdp --threads``, else torch's choice): what a unit
    runs with anywhere, since the last bits of a trained weight depend on it."""
    return torch.get_num_threads()


@dataclass(frozen=True)
class Unit:
    """One independent run: ``fn(*args, report=...)`` on a worker with ``cpus`` and ``gpus``. A unit
    computes with ``cpus`` threads, by default a local run's (:func:`local_threads`), so that its
    weights and numbers are the ones a local run makes, bit for bit."""

    label: str
    fn: Callable
    args: tuple = ()
    steps: int = 1  # what ``report`` counts up to: the length of the unit's bar
    cpus: int = field(default_factory=local_threads)
    gpus: float = 0.0


class LocalExecutor:
    """Every unit in this process, one after another, with this process's threads and folder."""

    def describe(self) -> str:
        return f"local executor, 1 worker, {local_threads()} thread(s)"

    def run(self, units: Sequence[Unit]) -> list:
        results = []
        for unit in units:
            with tqdm(total=unit.steps, desc=unit.label, unit="step", leave=True) as bar:
                results.append(unit.fn(*unit.args, report=lambda done, b=bar: b.update(done - b.n)))
        return results


class RayExecutor:
    """Every unit a Ray task, on the cluster at ``address`` (or a Ray started here with ``workers`` CPUs)."""

    def __init__(self, address: str | None = None, workers: int | None = None, retries: int = WORKER_RETRIES):
        try:
            self.ray = importlib.import_module("ray")
        except ModuleNotFoundError:
            raise ScdpError("--executor", "ray needs Ray, which is not installed: pip install 'scdp[cluster]'") from None
        if not self.ray.is_initialized():
            if address:
                self.ray.init(address=address, log_to_driver=True)
            else:
                self.ray.init(num_cpus=workers or os.cpu_count(), include_dashboard=False, log_to_driver=True)
        self.retries = retries
        self.workers = int(self.ray.cluster_resources().get("CPU", 0))
        self.gpus = int(self.ray.cluster_resources().get("GPU", 0))

    def describe(self) -> str:
        nodes = sum(1 for n in self.ray.nodes() if n.get("Alive"))
        return (f"Ray executor, {self.workers} worker CPU(s)" + (f" and {self.gpus} GPU(s)" if self.gpus else "")
                + f" on {nodes} node(s), {local_threads()} thread(s) per unit")

    def run(self, units: Sequence[Unit]) -> list:
        ray = self.ray
        nodes = [n.get("Resources", {}) for n in ray.nodes() if n.get("Alive")]
        for u in units:  # a task no node can hold would wait for ever: refuse it now
            if not any(n.get("CPU", 0) >= u.cpus and n.get("GPU", 0) >= u.gpus for n in nodes):
                largest = max((n.get("CPU", 0) for n in nodes), default=0)
                raise ScdpError("--threads", f"a unit computes with {u.cpus} thread(s) on as many CPUs"
                                + (f" and {u.gpus} GPU(s)" if u.gpus else "") + f", but the largest Ray node has "
                                f"{largest:g} CPU(s); pass scdp --threads {max(1, int(largest))} (and the same to "
                                "the local run you compare with) or add --workers")
        queue = importlib.import_module("ray.util.queue").Queue()  # progress, worker -> driver
        remote = ray.remote(_run_on_worker)
        refs = [remote.options(num_cpus=u.cpus, num_gpus=u.gpus, max_retries=self.retries, retry_exceptions=False,
                               name=u.label).remote(u.fn, u.args, os.getcwd(), u.cpus, queue, i)
                for i, u in enumerate(units)]
        bars = [tqdm(total=u.steps, desc=u.label, unit="step", position=i) for i, u in enumerate(units)]
        index = {ref: i for i, ref in enumerate(refs)}
        waiting, results = list(refs), [None] * len(refs)
        try:
            while waiting:
                done, waiting = ray.wait(waiting, num_returns=1, timeout=0.5)
                while not queue.empty():
                    i, count = queue.get_nowait()
                    bars[i].update(max(0, count - bars[i].n))
                for ref in done:
                    try:
                        results[index[ref]] = ray.get(ref)
                    except Exception as exc:  # the unit's own error, or its worker lost past the retries
                        for other in waiting:
                            ray.cancel(other, force=True)
                        cause = getattr(exc, "cause", None) or exc
                        if isinstance(cause, ScdpError):
                            raise cause from None
                        raise ScdpError(units[index[ref]].label, f"failed on its worker ({type(cause).__name__}: "
                                        f"{str(cause).strip().splitlines()[-1] if str(cause).strip() else ''}); run "
                                        "the command again to resume from the stages that finished") from None
                    bars[index[ref]].update(units[index[ref]].steps - bars[index[ref]].n)
        finally:
            for bar in bars:
                bar.close()
        return results


def _run_on_worker(fn: Callable, args: tuple, cwd: str, cpus: int, queue, index: int):
    """What a Ray worker runs: ``cpus`` threads, from the driver's folder, so relative paths (and the
    records that name them) are the same as a local run's (across machines that folder must be
    shared, docs/cluster.md); each step reported to the driver's ``queue``."""
    os.chdir(cwd)
    threads.configure(cpus)
    return fn(*args, report=lambda done: queue.put((index, done)))


def make_executor(name: str = LOCAL, *, address: str | None = None, workers: int | None = None):
    """The executor called ``name`` (``--executor``); ``address`` and ``workers`` are Ray's."""
    if name == LOCAL:
        if address or workers:
            raise ScdpError("--executor", "--ray-address and --workers are for --executor ray")
        return LocalExecutor()
    if name == RAY:
        if workers is not None and workers < 1:
            raise ScdpError("--workers", f"must be at least 1, got {workers}")
        return RayExecutor(address, workers)
    raise ScdpError("--executor", f"unknown executor {name!r} (choose from {', '.join(EXECUTORS)})")
