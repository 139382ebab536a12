"""The paper's evaluation protocol: scene sets × methods -> trajectory records.

Scene sets of a task (all seeded):

* ``ambiguous`` and ``non_ambiguous``: ``n`` random scenes each, drawn from the task's goal
  box and labelled by the probabilistic definition (eq. 3) at the start;
* ``config_1`` ... ``config_6``: the authors' fixed configurations, each with both targets
  (repeated ``config_repeats`` times: Figure 2 draws these).

Methods: ``dp`` (base Diffusion Policy), ``ld`` (Legibility Diffuser), ``scdp`` (automatic
style) and ``dataset``: one fresh demonstration of the same scene from the generator,
executed in the simulator, as the paper's "Dataset" row.
"""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from scdp import ambiguity
from scdp.data.bezier import sample_by_arc_length
from scdp.data.generate import execute_path
from scdp.evaluation.evaluate import scene_bounds, trajectory_record
from scdp.evaluation.rollout import Rollout, rollout

METHODS = ("dp", "ld", "scdp", "dataset")


def scene_sets(task, n: int, seed: int, config_repeats: int = 1) -> dict[str, list[tuple[np.ndarray, int]]]:
    """Random ambiguous / non-ambiguous scenes (n each) and the six configurations, each with
    both targets ``config_repeats`` times (repeats differ in start noise and sampling)."""
    rng = np.random.default_rng(seed)
    s = task.ambiguity
    sets: dict[str, list] = {"ambiguous": [], "non_ambiguous": []}
    while min(len(v) for v in sets.values()) < n:
        goals = task.sample_goals(rng, 2)
        target = int(rng.integers(2))
        amb = ambiguity.straight_margin(task.start_point, goals, target, s.beta) < s.tau
        key = "ambiguous" if amb else "non_ambiguous"
        if len(sets[key]) < n:
            sets[key].append((goals, target))
    for k in range(1, len(task.fixed_configs) + 1):
        sets[f"config_{k}"] = config_scenes(task, k, config_repeats)
    return sets


def config_scenes(task, k: int, repeats: int = 1) -> list[tuple[np.ndarray, int]]:
    """The authors' configuration ``k`` (1-based) with both targets, ``repeats`` times."""
    goals = task.fixed_configs[k - 1]
    return [(goals.copy(), t) for _ in range(repeats) for t in (0, 1)]


def dataset_rollouts(task, scenes, seed: int) -> list[Rollout]:
    """One generator demonstration per scene, executed in simulation (the "Dataset" row)."""
    rng = np.random.default_rng(seed)
    env = task.make_env()
    runs = []
    for goals, target in scenes:
        start_state = task.start_state(rng)
        start = task.task_space(start_state)
        ep = None
        while ep is None or not ep["success"]:
            control = task.sample_control_point(rng, start, goals[target])
            ep = execute_path(env, task, sample_by_arc_length(start, control, goals[target], task.step_size),
                              goals, target, start_state)
        runs.append(Rollout(goals=np.asarray(goals), target=int(target), path=list(task.episode_path(ep)),
                            states=list(ep["state"]), actions=list(ep["action"]), success=True, done=True))
    return runs


def evaluate_task(task, planners: dict, sets: dict, *, seed: int, progress: bool = True) -> list[dict]:
    """Every method on every scene of every set; returns the trajectory records.

    All scenes of all sets go through one batched rollout per method.
    """
    labelled = [(name, scene) for name, scenes in sets.items() for scene in scenes]
    scenes = [scene for _, scene in labelled]
    records, cache = [], {}
    for method in tqdm(METHODS, desc=f"evaluate {task.name}", unit="method", disable=not progress, mininterval=0.5):
        if method == "dataset":
            runs = dataset_rollouts(task, scenes, seed)
        else:
            runs = rollout(task, planners[method], scenes, seed=seed, progress=progress, desc=f"{task.name} {method}")
        records += [trajectory_record(task, r, method=method, scene_set=name, bounds=scene_bounds(task, r.goals, r.target, cache))
                    for (name, _), r in zip(labelled, runs)]
    return records
