"""Dynamic batching: concurrent requests share one network call.

Requests arrive on the server's event loop and wait in a bounded queue. One worker takes the
first waiting request, collects whatever else is waiting and, when the previous call served more
than one request (clients are arriving together), whatever else arrives within ``max_wait_s`` (up
to ``max_batch``). A lone client never waits for company it does not have: its request runs at
once, and requests that arrive while a call runs join the next one anyway. The worker groups the
collected requests by key (requests with different keys cannot share
a call, e.g. two methods), and runs each group with ``run_group(key, items)`` on a single worker
thread, so the network runs one call at a time while the event loop keeps accepting requests.

Overload is refused, not queued without bound: a request finding ``max_queue`` others waiting,
or one that waited longer than ``timeout_s`` before its turn, fails with :class:`Busy`.
"""

from __future__ import annotations

import asyncio
import time
from collections import defaultdict
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable, Hashable

from scdp.serve.batching import BatchingOptions


class Busy(RuntimeError):
    """The server is at capacity; the client should retry later (HTTP 503)."""


@dataclass
class _Waiting:
    key: Hashable
    item: Any
    future: asyncio.Future
    since: float


@dataclass
class BatchStats:
    """Counters since start: requests served, network calls made, requests refused as busy."""

    requests: int = 0
    calls: int = 0
    refused: int = 0
    largest_batch: int = 0

    def to_dict(self) -> dict:
        mean = self.requests / self.calls if self.calls else 0.0
        return {"requests": self.requests, "calls": self.calls, "mean_batch": round(mean, 2),
                "largest_batch": self.largest_batch, "refused": self.refused}


class DynamicBatcher:
    """Collect concurrent requests for a few milliseconds; run each key's group in one call.

    ``run_group(key, items) -> results`` runs on the worker thread and returns one result per
    item, in order; a result that is an exception is raised to that item's caller alone (the
    others of the group still get theirs). ``worker_init()`` runs once on that thread first. Start the
    worker with :meth:`start` inside the running event loop. ``clock`` (seconds) times each request's
    wait against ``timeout_s``; tests pass one they control.
    """

    def __init__(self, run_group: Callable[[Hashable, list], list], *, max_batch: int = BatchingOptions.max_batch,
                 max_wait_s: float = BatchingOptions.max_wait_ms / 1000,
                 max_queue: int = 256, timeout_s: float = 10.0, worker_init: Callable[[], None] | None = None,
                 clock: Callable[[], float] = time.perf_counter):
        self.run_group, self.max_batch, self.max_wait_s, self.clock = run_group, max_batch, max_wait_s, clock
        self.max_queue, self.timeout_s = max_queue, timeout_s
        self.stats = BatchStats()
        self.crowded = False  # the last call served more than one request: the next waits max_wait_s for company
        self._queue: asyncio.Queue | None = None
        self._task: asyncio.Task | None = None
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="scdp-planner", initializer=worker_init)

    def start(self) -> None:
        self._queue = asyncio.Queue()
        self._task = asyncio.get_running_loop().create_task(self._work())

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            await asyncio.gather(self._task, return_exceptions=True)
        self._executor.shutdown(wait=False, cancel_futures=True)

    async def submit(self, key: Hashable, item) -> Any:
        """Wait for ``item``'s result; raises :class:`Busy` when the queue is full or the wait too long."""
        if self._queue.qsize() >= self.max_queue:
            self.stats.refused += 1
            raise Busy(f"{self.max_queue} requests are already waiting")
        future = asyncio.get_running_loop().create_future()
        await self._queue.put(_Waiting(key, item, future, self.clock()))
        return await future

    async def run_alone(self, fn: Callable, *args) -> Any:
        """Run ``fn(*args)`` on the planner thread between batches (e.g. a whole simulated plan)."""
        return await asyncio.get_running_loop().run_in_executor(self._executor, fn, *args)

    async def _collect(self) -> list[_Waiting]:
        batch = [await self._queue.get()]
        deadline = time.perf_counter() + (self.max_wait_s if self.crowded else 0.0)
        while len(batch) < self.max_batch:
            left = deadline - time.perf_counter()
            if left <= 0 and self._queue.empty():
                break
            try:
                batch.append(self._queue.get_nowait() if not self._queue.empty() else
                             await asyncio.wait_for(self._queue.get(), left))
            except asyncio.TimeoutError:
                break
        self.crowded = len(batch) > 1
        return batch

    async def _work(self) -> None:
        loop = asyncio.get_running_loop()
        while True:
            batch = await self._collect()
            now, groups = self.clock(), defaultdict(list)
            for w in batch:
                if w.future.done():  # the client went away
                    continue
                if now - w.since > self.timeout_s:
                    self.stats.refused += 1
                    w.future.set_exception(Busy(f"waited more than {self.timeout_s:g} s for the planner"))
                    continue
                groups[w.key].append(w)
            for key, group in groups.items():
                try:
                    results = await loop.run_in_executor(self._executor, self.run_group, key, [w.item for w in group])
                except Exception as exc:  # noqa: BLE001 - handed to each waiting request
                    for w in group:
                        if not w.future.done():
                            w.future.set_exception(exc)
                    continue
                self.stats.calls += 1
                self.stats.requests += len(group)
                self.stats.largest_batch = max(self.stats.largest_batch, len(group))
                for w, result in zip(group, results):
                    if not w.future.done():
                        if isinstance(result, BaseException):
                            w.future.set_exception(result)
                        else:
                            w.future.set_result(result)
