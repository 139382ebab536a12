"""Procedural demonstrations: quadratic Bézier paths executed in the task's environment.

For each demo a scene is chosen (:func:`scdp.data.scenes.demo_scene`: a random scene, the
authors' six layouts in turn, or one of them only, with a random target), then
:func:`demonstrate` draws a path with :func:`scdp.data.bezier.demo_path` and the robot
follows it in simulation (through IK for the Panda). The recorded states are what the
simulator reports; the actions are the commanded next states.

A demonstration runs to the goal itself, not to the edge of the success radius where the
environment reports success: a policy learns to stop where its demonstrations stop, and
demonstrations cut at the radius teach it to halt on the radius's edge, where the smallest
error leaves it hovering just outside (measured: most failures of the cpu preset came within
1-7 cm of the radius and stayed there). After the path ends, the final command is held for
up to ``settle_steps`` steps until the robot is within :data:`ARRIVED` of the success radius
of the goal. Metrics do not see the difference: every path is cut at its first point inside
the radius before it is scored (:func:`scdp.scoring.score.cut_at_goal`). A path that does not
reach its target is reported and redrawn, ``max_attempts`` times, before the scene itself is
redrawn.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np
from tqdm.auto import tqdm

from scdp.data.bezier import demo_path, signed_bend, turning_path
from scdp.data.dataset import DemoDataset
from scdp.data.scenes import DEMOS, check_goal_count, demo_scene, stream_rng
from scdp.errors import ScdpError, non_negative_int
from scdp.keys import SCENE_MODES, TURN_FROM
from scdp.tasks import Task, get_task

ARRIVED = 0.2  # a demo has arrived within this fraction of the success radius of its goal
JUDGE_AFTER = 200  # attempts after which a run that accepts almost none of them stops (never hangs)
GIVE_UP_BELOW = 0.05  # ... below this share of accepted attempts
WARN_ABOVE = 0.2  # a finished dataset whose attempts were redrawn more often than this is reported as biased
TOO_LONG, UNREACHABLE, MISSED, TOO_FAST = "too long", "unreachable", "missed", "too fast"  # why an attempt was redrawn


@dataclass(frozen=True)
class GeneratorSettings:
    """What defines a generated dataset; stored in the zarr attributes."""

    task: str
    num_demos: int
    seed: int
    scenes: str = "random"  # "random" goals per demo, the six "fixed" layouts in turn, or one "layout_k"
    settle_steps: int = 30
    max_attempts: int = 20  # redraws of the control point before the scene is redrawn
    goals: int = 2  # goals per random scene: the target and goals - 1 distractors
    turning: float = 0.0  # share of demo paths that change course part-way (scdp.data.bezier.turning_path)
    turn_from: str = "start"  # their second course: another curve from the start, or one from the turn ("point")


def execute_path(env, task: Task, path: np.ndarray, goals, target: int, start_state, settle_steps: int = 30):
    """Follow a task-space ``path`` to its end in ``env``; returns an episode dict, or None if it fails.

    The episode holds ``state`` (T, S), ``action`` (T, S), ``goals``, ``target``, ``success``
    (the robot ended inside the success radius) and ``too_fast`` (the most of the robot's one-step reach an
    action asks for where that is over 1, else 0: such a path is no demonstration). The environment's success does not stop it:
    the path is followed to the goal, then held until within ``ARRIVED`` x the radius.
    """
    actions = task.actions_for_path(path, start_state)
    if actions is None:
        return None
    obs, info = env.reset(options={"goals": goals, "target": target, "start_state": start_state})
    states, sent = [], []
    hold = [actions[-1]] * settle_steps
    arrived = ARRIVED * task.success_radius
    for action in list(actions) + hold:
        states.append(obs["state"])
        sent.append(action)
        obs, _, _, truncated, info = env.step(action)
        if truncated or (len(sent) >= len(actions) and info["distance"] < arrived):
            break
    states, sent = np.array(states), np.array(sent)
    reach = float(task.reach_used(states, sent).max())
    return {
        "state": states,
        "action": sent,
        "goals": np.asarray(goals),
        "target": int(target),
        "success": bool(info["success"]),
        "final_distance": float(info["distance"]),
        "truncated": bool(truncated and not info["success"]),  # max_episode_steps ran out before the goal
        "path_steps": len(actions),  # steps the path itself takes, before any hold
        "too_fast": reach if reach > 1.0 else 0.0,
    }


class Failure(NamedTuple):
    """One redrawn attempt: why (:data:`TOO_LONG`, :data:`UNREACHABLE`, :data:`MISSED`), in words, the
    steps its path took (None: no path), and the demo it was an attempt at (None until that is known)."""

    kind: str
    words: str
    path_steps: int | None
    demo: int | None = None


def failure_reason(ep: dict | None) -> tuple[str, str]:
    """(kind, words) of a failed attempt: :data:`TOO_LONG`, :data:`UNREACHABLE`, :data:`TOO_FAST` or :data:`MISSED`."""
    if ep is None:
        return UNREACHABLE, "unreachable path"
    if ep["too_fast"]:
        return TOO_FAST, f"asks for {ep['too_fast']:.3g}x the robot's one-step reach (it turns too sharply)"
    if ep["truncated"]:
        return TOO_LONG, f"too long for max_episode_steps (its path takes {ep['path_steps']} steps)"
    return MISSED, f"ended {ep['final_distance']:.3f} m from target"


def demonstrate(task: Task, env, rng: np.random.Generator, goals, target: int, start_state, *, max_attempts: int = 20,
                settle_steps: int = 30, turning: float = 0.0, turn_from: str = "start") -> tuple[dict | None, list[str]]:
    """Draw demo paths for one scene and execute them until one reaches the target; each attempt is a
    :func:`~scdp.data.bezier.turning_path` (its second course from ``turn_from``) with probability ``turning``
    (no draw is made when it is 0).

    Returns (episode with its ``control_point``, or None after ``max_attempts`` failures; each failed
    attempt as a :class:`Failure`, :func:`failure_reason`).
    """
    start = task.task_space(start_state)
    failures = []
    for _ in range(max_attempts):
        if turning > 0 and rng.uniform() < turning:
            path, control = turning_path(task, rng, start, goals[target], from_point=turn_from == "point")
        else:
            path, control = demo_path(task, rng, start, goals[target])
        ep = execute_path(env, task, path, goals, target, start_state, settle_steps)
        if ep is not None and ep["success"] and not ep["too_fast"]:
            ep["control_point"] = control
            return ep, failures
        failures.append(Failure(*failure_reason(ep), None if ep is None else ep["path_steps"]))
    return None, failures


def rejection_summary(task: Task, failures: list, accepted_steps: list[int], attempts: int, settle_steps: int) -> str:
    """One line on why ``failures`` of ``attempts`` were redrawn, and what would change it."""
    counts = {k: sum(f.kind == k for f in failures) for k in (TOO_LONG, UNREACHABLE, MISSED, TOO_FAST)}
    words = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
    line = f"{len(failures)} of {attempts} attempts were redrawn ({len(failures) / max(attempts, 1):.0%}: {words})"
    long = [f.path_steps for f in failures if f.kind == TOO_LONG] + list(accepted_steps)
    if counts[TOO_LONG]:
        line += (f"; demo paths take {min(long)}-{max(long)} steps and max_episode_steps is {task.max_episode_steps}: "
                 f"raise it to at least {max(long) + settle_steps} (the path and its hold at the goal)")
    return line


def checked_settings(task: Task, num_demos, seed, scenes: str, settle_steps: int, max_attempts: int, n_goals,
                     turning: float, turn_from: str) -> GeneratorSettings:
    """:func:`generate_demos`'s arguments checked, each refused by name, as the settings a dataset records."""
    num_demos = non_negative_int(num_demos, "num_demos")
    seed = non_negative_int(seed, "seed")
    if num_demos == 0:
        raise ScdpError("num_demos", "must be at least 1")
    if scenes not in SCENE_MODES:
        raise ScdpError("scenes", f"unknown scene mode {scenes!r} (choose from {', '.join(SCENE_MODES)})")
    n_goals = check_goal_count(n_goals, scenes)
    if not 0.0 <= turning <= 1.0:
        raise ScdpError("turning", f"a share of demos from 0 to 1, got {turning}")
    if turn_from not in TURN_FROM:
        raise ScdpError("turn_from", f"one of {', '.join(TURN_FROM)}, got {turn_from!r}")
    return GeneratorSettings(task.name, num_demos, seed, scenes, settle_steps, max_attempts, n_goals, turning, turn_from)


def generate_demos(task: Task, num_demos: int, seed: int, *, scenes: str = "random", n_goals: int = 2,
                   progress: bool = True, settle_steps: int = 30, max_attempts: int = 20,
                   turning: float = 0.0, turn_from: str = "start") -> tuple[DemoDataset, dict]:
    """Generate ``num_demos`` successful demonstrations, each in a scene of ``n_goals`` goals
    (2..5; the layouts hold 2), a share ``turning`` of them changing course part-way. Returns (dataset, report).

    The report counts attempts, failures (dropped and redrawn) and lengths.
    """
    task = get_task(task)
    settings = checked_settings(task, num_demos, seed, scenes, settle_steps, max_attempts, n_goals, turning, turn_from)
    num_demos, seed, n_goals = settings.num_demos, settings.seed, settings.goals
    rng = stream_rng(DEMOS, seed)  # the demonstrations' own stream (scdp.data.scenes.STREAMS)
    env = task.make_env()
    env.reset(seed=seed)
    episodes, failures, attempts = [], [], 0
    bar = tqdm(total=num_demos, desc=f"generate {task.name}", unit="demo", disable=not progress, mininterval=0.5)
    while len(episodes) < num_demos:
        goals, target = demo_scene(task, scenes, len(episodes), rng, n_goals)
        ep, failed = demonstrate(task, env, rng, goals, target, task.start_state(rng), max_attempts=max_attempts,
                                 settle_steps=settle_steps, turning=turning, turn_from=turn_from)
        attempts += len(failed) + (ep is not None)
        failures += [f._replace(demo=len(episodes)) for f in failed]
        if ep is not None:
            episodes.append(ep)
            bar.update(1)
        bar.set_postfix(accepted=f"{len(episodes) / attempts:.0%}", redrawn=len(failures), refresh=False)
        if attempts >= JUDGE_AFTER and len(episodes) / attempts < GIVE_UP_BELOW:  # stop, never hang
            bar.close()
            why = rejection_summary(task, failures, [ep["path_steps"] for ep in episodes], attempts, settle_steps)
            raise ScdpError("demos", f"{len(episodes)} of {num_demos} demos after {attempts} attempts; {why}")
    bar.close()
    lengths = np.array([len(ep["state"]) for ep in episodes])
    bends = np.array([signed_bend(task.episode_path(ep)) for ep in episodes])
    report = {
        "task": task.name,
        "demos": len(episodes),
        "attempts": attempts,
        "failures": len(failures),
        "failure_reasons": [{"demo": f.demo, "reason": f.words} for f in failures[:20]],
        "warnings": ([f"{rejection_summary(task, failures, [e['path_steps'] for e in episodes], attempts, settle_steps)}: "
                      "the dataset under-represents what was redrawn (long, curved demos first when too long)"]
                     if len(failures) > WARN_ABOVE * attempts else []),
        "length_min": int(lengths.min()),
        "length_max": int(lengths.max()),
        "length_mean": float(lengths.mean()),
        "bend_abs_mean": float(np.abs(bends).mean()),
    }
    attrs = {
        "generator": asdict(settings),
        "seed": seed,
        "source": "scdp.generate",
        "control_points": np.array([ep["control_point"] for ep in episodes]),
        "report": {k: v for k, v in report.items() if k != "failure_reasons"},
    }
    return DemoDataset.from_episodes(task.name, episodes, attrs), report
