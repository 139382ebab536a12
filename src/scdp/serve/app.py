"""The planning service: trained policies over HTTP/JSON (FastAPI; OpenAPI schema at ``/openapi.json``).

Endpoints (``scdp serve --help`` starts it):

* ``POST /v1/act``: the call a robot's control loop makes once per chunk. It sends the states
  so far (oldest first), the goals and the target; it gets the next ``n_action_steps`` actions
  (absolute next states), the style that planned them and the server-side milliseconds.
  Concurrent calls are batched into one network call (:mod:`scdp.serve.batcher`). The service
  keeps no episode: Legibility Diffuser's guidance decay reads ``chunk_index``.
* ``POST /v1/plan``: a whole trajectory in the task's simulator, scored like ``scdp plan``.
* ``GET /v1/health`` and ``GET /v1/info``: liveness; task, methods, preset, device, shapes.

A malformed request gets HTTP 422 with ``{"error": "<field>: <problem>"}``, the CLI's one-line
form; an overloaded server answers 503 rather than queueing without bound.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np
import torch
from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, ConfigDict, Field

from scdp import threads
from scdp.devices import describe
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError, finite_array
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.keys import ALL_PLANNERS, SCDP_METHODS, STYLE_MODES
from scdp.policies.base import observe_histories
from scdp.policies.checkpoint import read_meta
from scdp.policies.legibility_diffuser import LegibilityDiffuser
from scdp.policies.loaders import load_method, planning_config
from scdp.serve.batcher import Busy, DynamicBatcher
from scdp.tasks import get_task

MAX_HISTORY = 64  # states a request may send; only the last n_obs_steps are used
MAX_SEED = 2**63 - 1


class ActRequest(BaseModel):
    """One scene at one replanning step."""

    model_config = ConfigDict(extra="forbid")
    state_history: list[list[float]] = Field(min_length=1, max_length=MAX_HISTORY,
                                             description="states so far, oldest first; at least the current one")
    goals: list[list[float]] = Field(min_length=2, max_length=16, description="every goal, task-space points")
    target: int = Field(0, ge=0, description="index of g* in goals")
    method: str = Field("scdp", description=f"one of {', '.join(ALL_PLANNERS)}")
    style: str = Field("auto", description=f"scdp only: {', '.join(STYLE_MODES)}")
    seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of this chunk's sampler noise")
    chunk_index: int = Field(0, ge=0, le=100_000, description="chunks already executed (Legibility Diffuser's decay)")


class PlanRequest(BaseModel):
    """One scene, planned and executed in the simulator from the task's start."""

    model_config = ConfigDict(extra="forbid")
    goals: list[list[float]] = Field(min_length=2, max_length=16)
    target: int = Field(0, ge=0)
    method: str = "scdp"
    style: str = "auto"
    seed: int = Field(0, ge=0, le=MAX_SEED)


def planner_key(method: str, style: str) -> tuple[str, str]:
    """(method, style) checked and made canonical: ``scdp`` + style, or a method without one."""
    if method not in ALL_PLANNERS:
        raise ScdpError("method", f"unknown method {method!r}; choose from {', '.join(ALL_PLANNERS)}")
    if style not in STYLE_MODES:
        raise ScdpError("style", f"unknown style {style!r}; choose from {', '.join(STYLE_MODES)}")
    if method in SCDP_METHODS:
        return "scdp", style if method == "scdp" else SCDP_METHODS[method]
    return method, "none"


class PlanningService:
    """Planners loaded on first use, one per (method, style); the batched ``act`` behind them."""

    def __init__(self, checkpoints, task, *, max_batch: int = 64, max_wait_ms: float = 5.0, max_queue: int = 256,
                 timeout_s: float = 10.0, sampler: str | None = None, steps: int | None = None, device="cpu"):
        self.task, self.root = get_task(task), Path(checkpoints)
        self.device = resolve_device(device)
        self.meta = read_meta(self.root / "base", "base", self.task)  # fails fast on a bad folder
        # the sampler every planner uses (the saved one unless replaced), checked now, not at the first request
        self.sampling = planning_config(self.meta["config"], sampler, steps)
        self.sampler, self.steps = sampler, steps
        self.planners: dict = {}
        # the pool is sized on the planner thread itself (scdp.threads.use_for_planning: one thread
        # unless the user chose; batch-1 chunks were ~4x slower on two sleeping threads)
        self.batcher = DynamicBatcher(self._act_group, max_batch=max_batch, max_wait_s=max_wait_ms / 1000,
                                      max_queue=max_queue, timeout_s=timeout_s, worker_init=self._init_planner_thread)
        self.threads: int | None = None  # torch threads of the planner thread, once it started

    def _init_planner_thread(self) -> None:
        self.threads = threads.use_for_planning(self.meta.get("parameters", 0))

    def planner(self, method: str, style: str):
        key = (method, style)
        if key not in self.planners:
            self.planners[key] = load_method(self.root, self.task, method, style if method == "scdp" else None,
                                             sampler=self.sampler, steps=self.steps, device=self.device)
        return self.planners[key]

    def check_history(self, states) -> np.ndarray:
        hist = finite_array(states, "state_history")
        if hist.ndim != 2 or hist.shape[1] != self.task.state_dim:
            raise ScdpError("state_history", f"expected states of {self.task.state_dim} values each, got shape {hist.shape}")
        return hist

    def _act_group(self, key, items: list[dict]) -> list[dict]:
        """One network call for requests sharing (method, style, chunk index); runs on the planner thread."""
        method, style, chunk = key
        planner = self.planner(method, style)
        if isinstance(planner, LegibilityDiffuser):
            planner.start_at_chunk(chunk)
        obs = observe_histories(self.task, [i["history"] for i in items], [i["goals"] for i in items],
                                [i["target"] for i in items], planner.n_obs_steps)
        generators = [torch.Generator().manual_seed(i["seed"]) for i in items]
        with torch.inference_mode():
            actions, styles = planner.act(obs, generators)
        actions = actions.double().numpy()
        return [{"actions": actions[b].tolist(), "style": styles[b], "batch_size": len(items)} for b in range(len(items))]

    def plan_scene(self, request: PlanRequest, goals: np.ndarray) -> dict:
        """A whole simulated trajectory for one request, scored (runs on the planner thread)."""
        method, style = planner_key(request.method, request.style)
        planner = self.planner(method, style)
        (run,) = rollout(self.task, planner, [(goals, request.target)], seed=request.seed)
        bounds = scene_bounds(self.task, goals, request.target)
        record = score_rollout(self.task, run, method=request.method, scene_set="custom", bounds=bounds).to_dict()
        return {**record, "actions": np.asarray(run.actions).tolist(), "planning_seconds": run.seconds}

    def info(self) -> dict:
        cfg = self.meta["config"]
        return {"task": self.task.name, "methods": list(ALL_PLANNERS), "styles": list(STYLE_MODES),
                "preset": self.meta.get("preset"), "device": describe(self.device),
                "threads": self.threads, "state_dim": self.task.state_dim,
                "space_dim": self.task.space_dim, "n_obs_steps": cfg.get("n_obs_steps"),
                "n_action_steps": cfg.get("n_action_steps"), "sampler": self.sampling.sampler,
                "inference_steps": self.sampling.num_inference_steps, "max_batch": self.batcher.max_batch,
                "max_wait_ms": self.batcher.max_wait_s * 1000, "batching": self.batcher.stats.to_dict()}


def create_app(service: PlanningService) -> FastAPI:
    """The FastAPI application around a :class:`PlanningService`."""

    @contextlib.asynccontextmanager
    async def lifespan(app):
        service.batcher.start()
        yield
        await service.batcher.stop()

    app = FastAPI(title="scdp planning service", version="1", lifespan=lifespan,
                  description="Style-Conditioned Diffusion Policy planners over HTTP/JSON.")

    @app.exception_handler(RequestValidationError)
    async def malformed(request: Request, exc: RequestValidationError):
        first = exc.errors()[0] if exc.errors() else {"loc": ("body",), "msg": "malformed request"}
        where = ".".join(str(p) for p in first.get("loc", ()) if p != "body") or "body"
        return JSONResponse(status_code=422, content={"error": f"{where}: {first.get('msg', 'invalid')}"})

    @app.exception_handler(ScdpError)
    async def refused(request: Request, exc: ScdpError):
        return JSONResponse(status_code=422, content={"error": str(exc)})

    @app.exception_handler(Busy)
    async def busy(request: Request, exc: Busy):
        return JSONResponse(status_code=503, content={"error": f"busy: {exc}"}, headers={"Retry-After": "1"})

    @app.get("/v1/health")
    async def health() -> dict:
        return {"status": "ok"}

    @app.get("/v1/info")
    async def info() -> dict:
        return service.info()

    @app.post("/v1/act")
    async def act(request: ActRequest) -> dict:
        t0 = time.perf_counter()
        method, style = planner_key(request.method, request.style)
        goals = service.task.validate_goals(request.goals, request.target)
        history = service.check_history(request.state_history)
        chunk = request.chunk_index if method in ("ld", "ld_paper") else 0
        item = {"history": history, "goals": goals, "target": request.target, "seed": request.seed}
        result = await service.batcher.submit((method, style, chunk), item)
        return {**result, "method": request.method, "server_ms": round(1000 * (time.perf_counter() - t0), 3)}

    @app.post("/v1/plan")
    async def plan(request: PlanRequest) -> dict:
        t0 = time.perf_counter()
        planner_key(request.method, request.style)
        goals = service.task.validate_goals(request.goals, request.target)
        result = await service.batcher.run_alone(service.plan_scene, request, goals)
        return {**result, "server_ms": round(1000 * (time.perf_counter() - t0), 3)}

    return app
