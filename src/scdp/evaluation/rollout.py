"""Receding-horizon rollouts of many scenes at once.

All scenes of a batch are planned by one network call per chunk (and per denoising step
inside it); only the environment stepping loops over scenes. A scene stops when its robot
enters the success radius or after ``task.max_episode_steps`` steps. The planner is any
:class:`~scdp.policies.base.Planner`; the rollout gives it ``planner.n_obs_steps`` past states.

Planning time: each chunk's wall time is shared equally among the scenes planned in it, so
``seconds`` is the amortised inference time of one trajectory.

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

from scdp.data.scenes import scene_seed
from scdp.policies.base import Chunk, Planner, WarmStart, act, observe_histories
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


def rollout(task: Task, planner: Planner, scenes, *, seed: int = 0, seeds: list[int] | None = None, progress: bool = False,
            desc: str = "rollout") -> list[Rollout]:
    """Run ``planner`` on ``scenes`` (a list of ``(goals, target)``) and return one Rollout each.

    Scene i has its own seed (``seeds[i]``, by default :func:`scdp.data.scenes.scene_seed` of
    ``seed`` and i): it seeds the start noise and a generator of its own for the sampler, so a
    scene gets the same noise whichever method plans it and whatever else is in the batch.
    """
    n_obs_steps = planner.n_obs_steps
    seeds = [scene_seed(seed, "", i) for i in range(len(scenes))] if seeds is None else list(seeds)
    envs = [task.make_env() for _ in scenes]
    runs = []
    for env, (goals, target), s in zip(envs, scenes, seeds):
        obs, _ = env.reset(seed=s, options={"goals": goals, "target": int(target)})
        runs.append(Rollout(goals=env.goals.copy(), target=int(target), path=[env.position.copy()], states=[obs["state"]]))
    planner.reset()
    generators = [torch.Generator().manual_seed(s) for s in seeds]
    previous: list[Chunk | None] = [None] * len(scenes)  # each scene's last chunk (B = 1 slices)
    bar = tqdm(total=len(scenes), desc=desc, unit="traj", disable=not progress, leave=False, mininterval=0.5)
    while True:
        active = [i for i, r in enumerate(runs) if not r.done]
        if not active:
            break
        obs = observe_histories(task, [runs[i].states for i in active], [runs[i].goals for i in active],
                                [runs[i].target for i in active], n_obs_steps, [envs[i].position for i in active])
        t0 = time.perf_counter()
        chunk = act(planner, obs, [generators[i] for i in active], warm_of([previous[i] for i in active]))
        actions, styles = chunk.actions, chunk.styles
        share = (time.perf_counter() - t0) / len(active)
        actions = actions.double().numpy()
        for j, i in enumerate(active):
            run, env = runs[i], envs[i]
            run.seconds += share
            run.styles.append(styles[j])
            run.starts.append(chunk.starts[j] if chunk.starts else "off")
            previous[i] = Chunk(actions[j:j + 1], styles[j:j + 1], None if chunk.plan is None else chunk.plan[j:j + 1],
                                None if chunk.weights is None else chunk.weights[j:j + 1])
            for a in actions[j]:
                o, _, terminated, truncated, info = env.step(a)
                run.actions.append(a)
                run.states.append(o["state"])
                run.path.append(env.position.copy())
                if terminated or truncated:
                    run.done, run.success = True, bool(info["success"])
                    bar.update(1)
                    break
    bar.close()
    return runs


def warm_of(previous: list) -> WarmStart:
    """The :class:`WarmStart` of B scenes from each one's last chunk (None: its first chunk, cold)."""
    known = [p is not None and p.plan is not None for p in previous]
    if not any(known):
        return WarmStart.cold_start(len(previous))
    like = previous[known.index(True)]
    plan = torch.cat([p.plan if k else torch.zeros_like(like.plan) for p, k in zip(previous, known)])
    weights = None if like.weights is None else np.concatenate(
        [p.weights if k else np.zeros(1) for p, k in zip(previous, known)])
    return WarmStart(plan=plan, weights=weights, executed=len(like.actions[0]),
                     cold=[None if k else "first" for k in known])
