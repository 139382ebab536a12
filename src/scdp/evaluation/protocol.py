"""The paper's evaluation protocol: scene sets × methods -> trajectory records.

Scene sets of a task (all seeded, from :func:`scdp.data.scenes.sample_scene`):

* ``ambiguous`` and ``non_ambiguous``: ``n`` random scenes each, labelled by the
  probabilistic definition (eq. 3) at the start;
* ``layout_1`` ... ``layout_6``: the authors' fixed layouts, each with both targets
  (repeated ``layout_repeats`` times: Figure 2 draws these).

Methods are planners by name (``dp``, ``ld``, ``scdp``, ...) and ``dataset``: one fresh
demonstration of the same scene from the generator, executed in the simulator, as the
paper's "Dataset" row.
"""

from __future__ import annotations

import numpy as np
from tqdm.auto import tqdm

from scdp import ambiguity
from scdp.data.generate import demonstrate
from scdp.data.scenes import (
    ATTENTION,
    EVALUATION,
    STUDY,
    VALIDATION,
    Scene,
    check_goal_count,
    layout_scenes,
    sample_scene,
    scene_seed,
    stream_rng,
)
from scdp.evaluation.records import TrajectoryRecord, scene_bounds, score_rollout
from scdp.evaluation.rollout import Rollout, rollout
from scdp.evaluation.tables import DATASET
from scdp.keys import AMBIGUOUS, CLEAR, LAYOUT_IDS, layout_name
from scdp.policies.base import Planner
from scdp.tasks import Task

DEMO_ATTEMPTS = 100  # paths drawn for a Dataset-row scene before it counts as a failure


def scene_sets(task: Task, n: int, seed: int, layout_repeats: int = 1, *, n_goals: int = 2,
               stream: str = EVALUATION) -> dict[str, list[Scene]]:
    """Random ambiguous / non-ambiguous scenes of ``n_goals`` goals (n each) and, for two goals,
    the six layouts, each with both targets ``layout_repeats`` times (repeats differ in start
    noise and sampling). With more goals a scene is ambiguous when eq. 3 holds against its most
    probable distractor (:func:`scdp.ambiguity.straight_margins`); the layouts hold two goals and
    are left out.

    ``stream`` is ``"evaluation"`` (what ``reproduce`` and ``evaluate`` report) or
    ``"validation"`` (what tuning and ablations may look at), ``"study"`` (what ``scdp study``
    shows people) or ``"attention"`` (the check scenes of studies before format 5): no two share a scene.
    """
    if stream not in (EVALUATION, VALIDATION, STUDY, ATTENTION):
        raise ValueError(f"scene sets come from the evaluation, validation, study or attention stream, not {stream!r}")
    n_goals = check_goal_count(n_goals)
    rng = stream_rng(stream, seed)
    sets: dict[str, list] = {AMBIGUOUS: [], CLEAR: []}
    start = task.start_point
    while min(len(v) for v in sets.values()) < n:
        goals, target = sample_scene(task, rng, n_goals)
        flag = ambiguity.probabilistic_flags(start[None], goals[None], np.array([target]), task.ambiguity)[0]
        key = AMBIGUOUS if flag else CLEAR
        if len(sets[key]) < n:
            sets[key].append((goals, target))
    for k in LAYOUT_IDS if n_goals == 2 else ():
        sets[layout_name(k)] = layout_scenes(task, k, layout_repeats)
    return sets


def dataset_rollouts(task: Task, scenes: list[Scene], seeds: list[int]) -> list[Rollout]:
    """One generator demonstration per scene, executed in simulation (the "Dataset" row), each
    drawn from its scene's own seed.

    A scene whose ``DEMO_ATTEMPTS`` drawn paths all miss the target is recorded as a failure
    (the last path is not kept: an empty path at the start).
    """
    env = task.make_env()
    runs = []
    for (goals, target), s in zip(scenes, seeds):
        rng = np.random.default_rng(s)
        start_state = task.start_state(rng)
        ep, _ = demonstrate(task, env, rng, goals, target, start_state, max_attempts=DEMO_ATTEMPTS)
        if ep is None:
            runs.append(Rollout(goals=np.asarray(goals), target=int(target), path=[task.task_space(start_state)] * 2,
                                states=[start_state], success=False, done=True))
            continue
        runs.append(Rollout(goals=np.asarray(goals), target=int(target), path=list(task.episode_path(ep)),
                            states=list(ep["state"]), actions=list(ep["action"]), success=True, done=True))
    return runs


def evaluate_methods(task: Task, planners: dict[str, Planner | None], sets: dict[str, list[Scene]], *, seed: int,
                     progress: bool = True) -> list[TrajectoryRecord]:
    """Every method on every scene of every set, in the order given; ``planners[DATASET]`` may be
    None (it needs no planner). All scenes of all sets go through one batched rollout per method."""
    labelled = [(name, i, scene) for name, scenes in sets.items() for i, scene in enumerate(scenes)]
    scenes = [scene for _, _, scene in labelled]
    seeds = [scene_seed(seed, name, i) for name, i, _ in labelled]
    records, cache = [], {}
    for method, planner in tqdm(planners.items(), desc=f"evaluate {task.name}", unit="method", disable=not progress,
                                mininterval=0.5):
        if method == DATASET:
            runs = dataset_rollouts(task, scenes, seeds)
        else:
            runs = rollout(task, planner, scenes, seeds=seeds, progress=progress, desc=f"{task.name} {method}")
        records += [score_rollout(task, r, method=method, scene_set=name, scene_index=i,
                                  bounds=scene_bounds(task, r.goals, r.target, cache))
                    for (name, i, _), r in zip(labelled, runs)]
    return records
