"""The planning service: trained policies over HTTP/JSON (FastAPI; OpenAPI schema at ``/openapi.json``).

Endpoints (``scdp serve --help`` starts it):

* ``POST /v1/act``: the call a robot's control loop makes once per chunk. It sends the states
  so far (oldest first), the goals and the target; it gets the next ``n_action_steps`` actions
  (absolute next states), the style that planned them and the server-side milliseconds.
  Concurrent calls are batched into one network call (:mod:`scdp.serve.batcher`). The service
  keeps no episode: Legibility Diffuser's guidance decay reads ``chunk_index``, and the warm start
  (``scdp serve --warm-skip K``) reads ``previous``, the last answer's ``plan`` and ``weight`` sent
  back with how many of its actions were taken. The planner then starts warm or cold by the rules
  the control-loop policy follows (:mod:`scdp.policies.control`): the answer's ``start`` says which.
* ``POST /v1/plan``: a whole trajectory in the task's simulator, scored like ``scdp plan``.
* ``GET /v1/health`` and ``GET /v1/info``: liveness and what runs (each loaded part's weights SHA-256 and runtime);
  task, methods served, preset, device, shapes.

Guard rails, because a robot stack may trust what comes back:

* before listening, :class:`PlanningService` loads every planner it serves, so a damaged,
  missing or mismatched part (hashes, shapes, the predictors a method needs) stops it at start;
* a request is checked whole: types are strict (``"1"`` and ``true`` are not integers), every
  state of ``state_history`` must be finite and inside the task's bounds
  (:meth:`~scdp.tasks.Task.state_bounds`), the goals inside the workspace, a style only where the
  method has a choice;
* every action returned is checked last (:meth:`~scdp.tasks.Task.check_chunk`): finite, inside the
  bounds and within :data:`~scdp.tasks.REACH_MARGIN` times the one-step reach of the state before
  it. A chunk that fails is not sent: the request gets 422 naming ``actions``. Nothing is clamped.

A refused request gets ``{"error": "<field>: <problem>"}`` (:mod:`scdp.serve.errors`), HTTP 422,
the CLI's one-line form; an overloaded server answers 503 rather than queueing without bound.
"""

from __future__ import annotations

import contextlib
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from fastapi import FastAPI
from pydantic import BaseModel, ConfigDict, Field

from scdp import planners, threads
from scdp.config import PlannerSpec, PlanningOptions
from scdp.devices import describe
from scdp.devices import resolve as resolve_device
from scdp.errors import ScdpError, refuse_repeats
from scdp.evaluation.records import BoundedCache, scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.keys import MAX_GOALS, PAPER_STYLE_PARTS, STUDENT_PART, STYLE_MODES
from scdp.messages import preview
from scdp.policies.base import Chunk, WarmStart, check_scene_goals, trained_goal_count
from scdp.policies.checkpoint import read_meta
from scdp.policies.control import plan_chunks
from scdp.policies.loaders import denoiser_part, load_method, loaded_parts, planning_config, without_graph
from scdp.serve.batcher import BatchingOptions, DynamicBatcher
from scdp.serve.errors import install_error_handlers
from scdp.serve.limits import BodyLimit
from scdp.tasks import Task, get_task

MAX_HISTORY = 64  # states a request may send; only the last n_obs_steps are used, all are checked
MAX_HORIZON = 1024  # rows a previous plan may hold (it must match the model's horizon exactly)
MAX_SEED = 2**63 - 1
BOUNDS_MEMO = 4096  # scenes whose reference bounds /v1/plan keeps (4 floats each, with the key ~0.3 kB)
NAME_CHARS = 64  # longest method or style name a request may send
MAX_BODY_BYTES = 4 * 2**20  # a request larger than this is refused (413) before it is read whole


class PreviousChunk(BaseModel):
    """The previous answer for this robot, sent back so the next chunk can start from it."""

    model_config = ConfigDict(extra="forbid", strict=True)
    plan: list[list[float]] = Field(min_length=1, max_length=MAX_HORIZON,
                                    description="the previous answer's plan (its whole horizon, absolute states)")
    weight: float | None = Field(description="the previous answer's legible weight (null for a planner without style)")
    executed: int = Field(ge=1, le=MAX_HORIZON, description="how many of the previous answer's actions were taken")
    goals: list[list[float]] | None = Field(None, max_length=MAX_GOALS, description=(
        "the goals the previous answer was planned for (its request's); when they differ from this request's "
        "(a goal appeared, vanished or moved), the chunk starts cold and says so (start: goals)"))


class ActRequest(BaseModel):
    """One scene at one replanning step."""

    model_config = ConfigDict(extra="forbid", strict=True)
    state_history: list[list[float]] = Field(min_length=1, max_length=MAX_HISTORY,
                                             description="states so far, oldest first; at least the current one")
    goals: list[list[float]] = Field(min_length=2, max_length=MAX_GOALS, description="every goal, task-space points")
    target: int = Field(0, ge=0, le=MAX_GOALS - 1, description="index of g* in goals (an integer, not a string)")
    method: str = Field("scdp", max_length=NAME_CHARS, description=f"one of {', '.join(planners.names())}")
    style: str | None = Field(None, max_length=NAME_CHARS,
                              description=f"scdp only ({', '.join(STYLE_MODES)}; default auto); refused elsewhere")
    seed: int = Field(0, ge=0, le=MAX_SEED, description="seed of this chunk's sampler noise")
    chunk_index: int = Field(0, ge=0, le=100_000, description="chunks already executed (Legibility Diffuser's decay)")
    previous: PreviousChunk | None = Field(None, description="the last answer, for a warm start (scdp serve --warm-skip)")


class PlanRequest(BaseModel):
    """One scene, planned and executed in the simulator from the task's start."""

    model_config = ConfigDict(extra="forbid", strict=True)
    goals: list[list[float]] = Field(min_length=2, max_length=MAX_GOALS)
    target: int = Field(0, ge=0, le=MAX_GOALS - 1)
    method: str = Field("scdp", max_length=NAME_CHARS)
    style: str | None = Field(None, max_length=NAME_CHARS)
    seed: int = Field(0, ge=0, le=MAX_SEED)


def previous_warm(previous: list[dict | None], executed: int) -> WarmStart:
    """The warm start of a group of requests from what each sent back (None: the robot's first chunk; a
    previous answer planned for other goals starts cold, ``goals``)."""
    moved = [p is not None and p.get("moved", False) for p in previous]
    return WarmStart.of_scenes([None if p is None or m else p["plan"] for p, m in zip(previous, moved)],
                               [None if p is None or m else p["weight"] for p, m in zip(previous, moved)], executed,
                               ["goals" if m else None for m in moved])


def answer_of(chunk: Chunk, b: int) -> dict:
    """What an act answer says of scene ``b`` beside its actions: the style, how its sampling began, and
    what the next request sends back as ``previous`` (the plan, never to be executed, and the weight)."""
    return {"style": chunk.styles[b], "start": chunk.starts[b] if chunk.starts else "off",
            "plan": None if chunk.plan is None else chunk.plan[b].tolist(),
            "weight": None if chunk.weights is None else float(chunk.weights[b])}


OPTIONAL_PARTS = (*PAPER_STYLE_PARTS, STUDENT_PART)  # served by default only where the folder holds them


def served_methods(root: Path, methods=None) -> tuple[str, ...]:
    """The planners a service offers: ``methods`` (checked, no repeats), or by default every one of
    scdp's own planners but those reading an optional part (:data:`OPTIONAL_PARTS`: ``scdp_paper``'s
    predictors, the few-step student), which join when the folder holds one of their optional parts (and
    then must hold them all)."""
    if methods is None:
        def joins(method: str) -> bool:
            optional = [p for p in planners.kind(method).parts if p in OPTIONAL_PARTS]
            return not optional or any((root / p).exists() for p in optional)
        return tuple(m for m in planners.names() if planners.kind(m).load is None and joins(m))
    unknown = [m for m in methods if m not in planners.names()]
    if unknown:
        raise ScdpError("--methods", f"unknown method {preview(unknown[0])}; choose from {', '.join(planners.names())}")
    refuse_repeats(methods, "--methods")
    return tuple(methods)


def requested_spec(method: str, style: str | None, served=None) -> PlannerSpec:
    """A request's (method, style) as its :class:`~scdp.config.PlannerSpec`.

    Refuses an unknown method, one this service does not serve, and a style that the method has
    no choice of or that contradicts the one it fixes (:meth:`~scdp.config.PlannerSpec.of`).
    """
    if served is not None and method in planners.names() and method not in served:
        raise ScdpError("method", f"{method} is not served here (serving {', '.join(served)})")
    return PlannerSpec.of(method, style, field="style", method_field="method")


class PlanningService:
    """Every served planner, loaded and checked at construction; the batched ``act`` behind them."""

    def __init__(self, checkpoints, task: Task | str, *, methods=None, batching: BatchingOptions = BatchingOptions(),
                 planning: PlanningOptions | None = None):
        self.task, self.root = get_task(task), Path(checkpoints)
        if not self.root.is_dir():
            raise ScdpError("--checkpoints", f"{self.root} is not a folder")
        planning = PlanningOptions.of_entry("serve") if planning is None else planning  # the real-time planner
        self.device = resolve_device(planning.device)
        self.meta = read_meta(self.root / "base", "base", self.task)
        self.methods = served_methods(self.root, methods)
        # --runtime onnx serves what it can: a denoiser without an exported graph runs in torch, named at start
        missing = without_graph(self.root, self.methods, planning)
        self.torch_parts = set(missing.values())
        self.notes = [f"--runtime onnx: checkpoints/{part} has no exported denoiser, so "
                      f"{', '.join(m for m in missing if missing[m] == part)} run it in torch here (scdp export "
                      f"--task {self.task.name} --checkpoints {self.root} writes its graph)" for part in sorted(self.torch_parts)]
        self.planning = planning
        # how each served method plans (the profile fills what was not given), checked now, not at the first request
        specs = {m: PlannerSpec.parse(m, field="--methods") for m in self.methods}
        self.planning_of = {m: self.planning_for(spec).for_method(spec.method) for m, spec in specs.items()}
        self.sampling = {m: planning_config(self.meta["config"], o.sampler, o.steps) for m, o in self.planning_of.items()}
        self.planners: dict[PlannerSpec, object] = {}
        for method in self.methods:  # every part each method needs: read, hashed, shaped, now
            self.planner(PlannerSpec.of(method))
        self.parts = loaded_parts(self.root, self.methods, self.task, planning)
        self.n_goals = trained_goal_count(self.planners.values())  # the scene encoder's goal count (scdp), or None
        # the pool is sized on the planner thread itself (scdp.threads.use_for_planning: one thread
        # unless the user chose; batch-1 chunks were ~4x slower on two sleeping threads)
        self.batcher = DynamicBatcher(self._act_group, max_batch=batching.max_batch, max_wait_s=batching.max_wait_ms / 1000,
                                      max_queue=batching.max_queue, timeout_s=batching.timeout_s,
                                      worker_init=self._init_planner_thread)
        self.threads: int | None = None  # torch threads of the planner thread, once it started
        self.bounds_memo = BoundedCache(BOUNDS_MEMO)  # scenes /v1/plan scored: their reference bounds

    def _init_planner_thread(self) -> None:
        self.threads = threads.use_for_planning(self.meta.get("parameters", 0))

    def planner(self, spec: PlannerSpec):
        """The planner of a spec; scdp's other styles load on first use (their parts were checked)."""
        if spec not in self.planners:
            self.planners[spec] = load_method(spec, self.root, self.task, self.planning_for(spec))
        return self.planners[spec]

    def planning_for(self, spec: PlannerSpec) -> PlanningOptions:
        """The service's planning options for ``spec``: torch for a denoiser that has no graph."""
        return replace(self.planning, runtime="torch") if denoiser_part(spec) in self.torch_parts else self.planning

    def check_history(self, states) -> np.ndarray:
        """A request's states (T, state_dim), every one finite and inside the task's bounds."""
        hist = self.task.check_states(states, "state_history")
        if hist.ndim != 2:
            raise ScdpError("state_history", f"expected a list of states, got shape {hist.shape}")
        return hist

    def check_request(self, request) -> tuple[PlannerSpec, np.ndarray]:
        """What ``/v1/act`` and ``/v1/plan`` check first: the method and style served, the goals (K, d)
        valid and of the count the planner reads. Returns (spec, goals)."""
        spec = requested_spec(request.method, request.style, self.methods)
        goals = self.task.validate_goals(request.goals, request.target)
        self.check_scene(spec, goals)
        return spec, goals

    def check_scene(self, spec: PlannerSpec, goals: np.ndarray) -> None:
        """Refuse a scene the planner cannot read: SCDP's encoder was trained for a fixed goal count."""
        if spec.has_encoder:
            check_scene_goals(self.n_goals, len(goals), "goals")

    def check_previous(self, spec: PlannerSpec, previous: PreviousChunk | None, goals: np.ndarray | None = None) -> dict | None:
        """A request's previous answer as the warm start reads it: its plan (H, S) float32, the right
        shape and finite; a weight exactly where the method has a style; at most a chunk executed."""
        if previous is None:
            return None
        cfg = self.meta["config"]
        plan = np.asarray(previous.plan, dtype=np.float64)
        if plan.shape != (cfg["horizon"], self.task.state_dim):
            raise ScdpError("previous.plan", f"expected the previous answer's plan of shape "
                                             f"({cfg['horizon']}, {self.task.state_dim}), got {plan.shape}")
        if not np.all(np.isfinite(plan)):
            raise ScdpError("previous.plan", "contains NaN or inf")
        styled = spec.has_encoder  # the SCDP planners, whose every answer carries a legible weight
        if styled != (previous.weight is not None):
            raise ScdpError("previous.weight", f"send back the weight the previous answer returned ({spec.method} "
                                               f"{'has' if styled else 'has no'} style, so it is "
                                               f"{'a number from 0 to 1' if styled else 'null'})")
        if previous.weight is not None and not 0.0 <= previous.weight <= 1.0:
            raise ScdpError("previous.weight", f"must be from 0 to 1, got {previous.weight}")
        if previous.executed > cfg["n_action_steps"]:
            raise ScdpError("previous.executed", f"a chunk holds {cfg['n_action_steps']} actions, got {previous.executed}")
        moved = False  # the previous answer was planned for other goals: its plan is not this scene's
        if previous.goals is not None and goals is not None:
            before = self.task.validate_goals(previous.goals, field="previous.goals")
            moved = before.shape != goals.shape or not np.array_equal(before, goals)
        return {"plan": plan.astype(np.float32), "weight": previous.weight, "executed": previous.executed, "moved": moved}

    def _plan_group(self, key, items: list[dict]) -> list[tuple[np.ndarray, dict, int]]:
        """(chunk (n_action_steps, state_dim) float64, what else the answer says, batch size) of each
        item, unchecked: requests sharing (planner spec, chunk index, actions executed since the previous
        chunk), one network call per goal count; runs on the planner thread."""
        spec, chunk, executed = key
        planner = self.planner(spec)
        planned: list = [None] * len(items)
        by_count = defaultdict(list)  # scenes of different goal counts cannot share one tensor
        for i, item in enumerate(items):
            by_count[len(item["goals"])].append(i)
        for rows in by_count.values():
            group = [items[i] for i in rows]
            generators = [torch.Generator().manual_seed(i["seed"]) for i in group]
            planned_group = plan_chunks(planner, self.task, [i["history"] for i in group], [i["goals"] for i in group],
                                        [i["target"] for i in group], generators,  # as the control-loop policy plans
                                        warm=previous_warm([i.get("previous") for i in group], executed),
                                        chunk_index=[chunk] * len(group))
            for b, i in enumerate(rows):
                planned[i] = (planned_group.actions[b], answer_of(planned_group, b), len(rows))
        return planned

    def _act_group(self, key, items: list[dict]) -> list:
        """:meth:`_plan_group`, then every chunk through :meth:`~scdp.tasks.Task.check_chunk`: a chunk
        that fails comes back as its error (that request gets 422 on ``actions``), the others as answers."""
        results: list = []
        for item, (actions, answer, batch) in zip(items, self._plan_group(key, items)):
            try:
                checked = self.task.check_chunk(item["history"][-1], actions)
            except ScdpError as err:
                results.append(err)
                continue
            results.append({"actions": checked.tolist(), **answer, "batch_size": batch})
        return results

    def check_trajectory(self, run, planner) -> None:
        """Each executed chunk of a rollout as :meth:`~scdp.tasks.Task.check_chunk` checks one: from the
        state it was planned at, action after action."""
        n = planner.n_action_steps
        for j, start in enumerate(range(0, len(run.actions), n)):
            try:
                self.task.check_chunk(run.states[start], np.asarray(run.actions[start:start + n]))
            except ScdpError as err:
                raise ScdpError(err.field, f"chunk {j}: {err.message}") from None

    def plan_scene(self, request: PlanRequest, goals: np.ndarray) -> dict:
        """A whole simulated trajectory for one request, scored (runs on the planner thread)."""
        planner = self.planner(requested_spec(request.method, request.style, self.methods))
        (run,) = rollout(self.task, planner, [(goals, request.target)], seed=request.seed)
        if run.failure:  # a chunk that left (or would leave) the bounds: refused, as a robot would be spared it
            raise ScdpError("actions", f"{run.failure}; the plan was not sent")
        self.check_trajectory(run, planner)
        bounds = scene_bounds(self.task, goals, request.target, self.bounds_memo)  # once per scene
        record = score_rollout(self.task, run, method=request.method, scene_set="custom", bounds=bounds).to_dict()
        return {**record, "actions": np.asarray(run.actions).tolist(), "planning_seconds": run.seconds}

    def info(self) -> dict:
        cfg = self.meta["config"]
        main = "scdp" if "scdp" in self.methods else self.methods[0]  # the sampler and steps reported at the top
        low, high = self.task.state_bounds()
        return {"task": self.task.name, "methods": list(self.methods), "styles": list(STYLE_MODES),
                "preset": self.meta.get("preset"), "device": describe(self.device),
                "threads": self.threads, "state_dim": self.task.state_dim, "state_low": low.tolist(),
                "state_high": high.tolist(), "space_dim": self.task.space_dim, "n_goals": self.n_goals,
                "n_obs_steps": cfg.get("n_obs_steps"), "n_action_steps": cfg.get("n_action_steps"),
                "sampler": self.sampling[main].sampler, "inference_steps": self.sampling[main].num_inference_steps,
                "profile": self.planning.profile,  # how each method plans (LD keeps its trained sampler under realtime):
                "planning": {m: {"sampler": self.sampling[m].sampler, "inference_steps": self.sampling[m].num_inference_steps,
                                 "warm_skip": o.warm_skip, "runtime": o.runtime, "cuda_graphs": o.cuda_graphs}
                             for m, o in self.planning_of.items()},
                "max_batch": self.batcher.max_batch, "max_wait_ms": self.batcher.max_wait_s * 1000,
                "batching": self.batcher.stats.to_dict(), "parts": self.parts}


def create_app(service: PlanningService) -> FastAPI:
    """The FastAPI application around a :class:`PlanningService`."""

    @contextlib.asynccontextmanager
    async def lifespan(app):
        service.batcher.start()
        yield
        await service.batcher.stop()

    app = FastAPI(title="scdp planning service", version="1", lifespan=lifespan,
                  description="Style-Conditioned Diffusion Policy planners over HTTP/JSON.")
    install_error_handlers(app)
    app.add_middleware(BodyLimit, max_bytes=MAX_BODY_BYTES)

    @app.get("/v1/health")
    async def health() -> dict:
        return {"status": "ok", "parts": service.parts}

    @app.get("/v1/info")
    async def info() -> dict:
        return service.info()

    @app.post("/v1/act")
    async def act(request: ActRequest) -> dict:
        t0 = time.perf_counter()
        spec, goals = service.check_request(request)
        history = service.check_history(request.state_history)
        previous = service.check_previous(spec, request.previous, goals)
        chunk = request.chunk_index if spec.family == "ld" else 0
        executed = previous["executed"] if previous else service.meta["config"]["n_action_steps"]
        item = {"history": history, "goals": goals, "target": request.target, "seed": request.seed, "previous": previous}
        result = await service.batcher.submit((spec, chunk, executed), item)
        return {**result, "method": request.method, "server_ms": round(1000 * (time.perf_counter() - t0), 3)}

    @app.post("/v1/plan")
    async def plan(request: PlanRequest) -> dict:
        t0 = time.perf_counter()
        _, goals = service.check_request(request)
        result = await service.batcher.run_alone(service.plan_scene, request, goals)
        return {**result, "server_ms": round(1000 * (time.perf_counter() - t0), 3)}

    return app
