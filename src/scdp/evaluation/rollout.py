"""Receding-horizon rollouts of many scenes at once.

All scenes of a batch are planned by one network call per chunk (and per denoising step
inside it); only the environment stepping loops over scenes. A scene stops when its robot
enters the success radius or after ``task.max_episode_steps`` steps. The planner is any
:class:`~scdp.policies.base.Planner`; the rollout gives it ``planner.n_obs_steps`` past states.

Planning time: each chunk's wall time is shared equally among the scenes planned in it, so
``seconds`` is the amortised inference time of one trajectory.

A rollout that leaves the task's state bounds, or is handed a chunk that would, ends there as a
failure of that rollout alone, with its reason in ``failure`` (``planned action out of bounds:
...`` before the environment steps, ``left the state bounds at step k: ...`` after); the other
scenes and methods go on. (The planning service and deploy refuse such a chunk before a robot
sees it: :meth:`scdp.tasks.Task.check_chunk`.)

Warm starts (a planner whose base has ``warm_skip`` > 0): each scene's previous chunk is handed
to the planner, which starts the scene cold at its first chunk, after a style change, or off its
plan (:mod:`scdp.policies.diffusion`); ``starts`` records how each chunk began.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import torch
from tqdm.auto import tqdm

from scdp.data.scenes import SceneEvent, scene_seed
from scdp.errors import ScdpError
from scdp.policies.base import Planner, WarmStart
from scdp.policies.control import plan_chunks
from scdp.tasks import Task


@dataclass
class Rollout:
    """One scene's executed episode: task-space path (T + 1, G), states and actions (T, S),
    the style of each chunk, success and its share of the planning time in seconds."""

    goals: np.ndarray
    target: int
    path: list = field(default_factory=list)  # task-space points, start included
    states: list = field(default_factory=list)
    actions: list = field(default_factory=list)
    styles: list = field(default_factory=list)  # one per executed chunk
    starts: list = field(default_factory=list)  # one per chunk: "warm", or why it started cold ("off": no warm start)
    success: bool = False
    seconds: float = 0.0
    done: bool = False
    failure: str = ""  # why the rollout was ended early as a failure ("" when it ran its course)
    event: dict | None = None  # the scene change it met: kind, step, goals, target and the first chunk planned after it

    def fail(self, reason: str) -> None:
        self.done, self.success, self.failure = True, False, reason


def rollout(task: Task, planner: Planner, scenes, *, seed: int = 0, seeds: list[int] | None = None,
            noise_seeds: list[int] | None = None, progress: bool = False, desc: str = "rollout",
            events: list[SceneEvent | None] | None = None) -> list[Rollout]:
    """Run ``planner`` on ``scenes`` (a list of ``(goals, target)``) and return one Rollout each.

    Scene i has its own seed (``seeds[i]``, by default :func:`scdp.data.scenes.scene_seed` of
    ``seed`` and i): it seeds the start noise and a generator of its own for the sampler, so a
    scene gets the same noise whichever method plans it and whatever else is in the batch.
    ``noise_seeds`` seeds the sampler's generators apart from the start states (a null check that
    redraws only the sampler noise); by default they are ``seeds``.

    ``events[i]`` (a :class:`~scdp.data.scenes.SceneEvent`, or None) changes scene i during its
    motion: once the robot has taken ``event.step`` actions its environment's goals move
    (:meth:`~scdp.envs.base.GoalReachEnv.move_goals`), the chunk under way goes on, and every later
    chunk is planned for the new goals, starting cold (``goals``: the last plan was for another scene).
    """
    seeds = [scene_seed(seed, "", i) for i in range(len(scenes))] if seeds is None else list(seeds)
    envs = [task.make_env() for _ in scenes]
    runs = []
    for env, (goals, target), s in zip(envs, scenes, seeds):
        obs, _ = env.reset(seed=s, options={"goals": goals, "target": int(target)})
        runs.append(Rollout(goals=env.goals.copy(), target=int(target), path=[env.position.copy()], states=[obs["state"]]))
    planner.reset()
    generators = [torch.Generator().manual_seed(s) for s in (seeds if noise_seeds is None else noise_seeds)]
    plans: list = [None] * len(scenes)  # each scene's last plan (H, S) and its legible weight: its warm start
    weights: list = [None] * len(scenes)
    events = [None] * len(scenes) if events is None else list(events)
    cold: list = [None] * len(scenes)  # a reason the next chunk starts cold that the rollout knows ("goals")
    bar = tqdm(total=len(scenes), desc=desc, unit="traj", disable=not progress, leave=False, mininterval=0.5)
    while True:
        active = [i for i, r in enumerate(runs) if not r.done]
        if not active:
            break
        warm = WarmStart.of_scenes([plans[i] for i in active], [weights[i] for i in active], planner.n_action_steps,
                                   [cold[i] for i in active])
        t0 = time.perf_counter()
        chunk = plan_chunks(planner, task, [runs[i].states for i in active], [envs[i].goals for i in active],
                            [envs[i].target for i in active], [generators[i] for i in active],
                            [envs[i].position for i in active], warm)
        share = (time.perf_counter() - t0) / len(active)
        for j, i in enumerate(active):
            run, env = runs[i], envs[i]
            run.seconds += share
            run.styles.append(chunk.styles[j])
            run.starts.append(chunk.starts[j] if chunk.starts else "off")
            plans[i] = None if chunk.plan is None else chunk.plan[j].numpy()
            weights[i] = None if chunk.weights is None else float(chunk.weights[j])
            cold[i] = None
            try:
                task.check_states(chunk.actions[j], "actions", what="step")
            except ScdpError as exc:
                run.fail(f"planned action out of bounds: {exc.message}")
                bar.update(1)
                continue
            for a in chunk.actions[j]:
                o, _, terminated, truncated, info = env.step(a)
                run.actions.append(a)
                run.states.append(o["state"])
                run.path.append(info["position"])
                left = _outside(task, o["state"])
                if left:
                    run.fail(f"left the state bounds at step {len(run.actions)}: {left}")
                elif terminated or truncated:
                    run.done, run.success = True, bool(info["success"])
                if run.done:
                    bar.update(1)
                    break
                event = events[i]
                if event is not None and run.event is None and len(run.actions) >= event.step:
                    env.move_goals(event.goals, event.target)
                    run.event = {"kind": event.kind, "step": len(run.actions), "chunk": len(run.styles),
                                 "goals": env.goals.copy(), "target": env.target}
                    plans[i], cold[i] = None, "goals"
    bar.close()
    return runs


def _outside(task: Task, state) -> str:
    """What is wrong with ``state`` (outside the bounds, or not finite), or "" when it is fine."""
    try:
        task.check_states(state, "state")
    except ScdpError as exc:
        return exc.message.removeprefix("state 0: ")
    return ""
