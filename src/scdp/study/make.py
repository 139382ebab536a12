"""``scdp study make``: roll the methods out on the study's scenes and write a self-contained study folder.

The folder::

    study.json        settings, scenes, every stimulus (task-space goals and path), the design, the
                      checkpoints' SHA-256s and the command: everything needed to rerun it
    frames/<hash>.jpg Block Reach only: the motion as JPEG frames from a person's view across the table
                      (the page draws the goals' colours and the TCP's path so far on them), named by
                      their content's SHA-256 so no name tells the method, scene or goal

Navigation stimuli are drawn by the page from the JSON alone (a top view). Nothing is a video:
the page animates the path itself, so no codec is needed and the playback time of each response
is known exactly.
"""

from __future__ import annotations

import hashlib
import json
import secrets
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from scdp import __version__
from scdp.content import file_sha256
from scdp.data.scenes import STUDY, scene_seed
from scdp.deploy.media import render_poses
from scdp.errors import ScdpError
from scdp.evaluation.protocol import scene_sets
from scdp.evaluation.rollout import rollout
from scdp.io import atomic_path, check_output_path, write_json
from scdp.perception import observer_camera
from scdp.policies.base import trained_goal_count
from scdp.policies.loaders import load_method
from scdp.robots.panda_meshes import arm_words
from scdp.scoring import cut_at_goal
from scdp.study.design import main_stimuli, stimulus_id
from scdp.study.record import MAIN, PRACTICE, SETS, Stimulus, Study, StudyConfig, View, frame_rate, point_seconds
from scdp.tasks import Task, task_reference

STUDY_FILE = "study.json"
FRAME_SIZE = (480, 360)  # with JPEG_QUALITY, about 15 kB a frame: a 6 s motion at 15 fps is about 1.4 MB
JPEG_QUALITY = 75
NEUTRAL_BLOCK_RGBA = (0.82, 0.82, 0.82, 1.0)  # every block alike: the page colours the goals per participant


def study_scenes(task: Task, n: int, seed: int, n_goals: int) -> tuple[dict, tuple]:
    """The study's ``n`` ambiguous and ``n`` clear scenes and its practice scene (a clear one), from the
    study stream. Each set keeps eq. 3's classification, but its targets' rank by distance from the
    start (nearest, ..., farthest) is balanced (each rank ``n / n_goals`` times, the remainder drawn):
    scenes are taken in the stream's order, skipping those whose rank is already full, so neither the
    goals nor the start predict the answer (eq. 3's sets alone lean towards the nearer goal)."""
    rng = np.random.default_rng(scene_seed(seed, "study-ranks", 0))
    quotas = {name: np.bincount(rng.permutation(np.arange(n) % n_goals)[:n], minlength=n_goals) for name in SETS}
    pool = 4 * n
    while True:
        sets = scene_sets(task, pool, seed, n_goals=n_goals, stream=STUDY)
        picked, practice = {}, None
        for name in SETS:
            left, picked[name] = quotas[name].copy(), []
            for goals, target in sets[name]:
                rank = int(np.argsort(np.argsort(np.linalg.norm(np.asarray(goals)[:, :len(task.start_point)]
                                                                - task.start_point, axis=1), kind="stable"))[target])
                if left[rank] > 0:
                    left[rank] -= 1
                    picked[name].append((goals, target))
                elif name == SETS[1] and practice is None:
                    practice = (goals, target)
        if all(len(v) == n for v in picked.values()) and practice is not None:
            return picked, practice
        pool *= 2  # a rank rarer than the pool allowed for: draw more


def shown_length(task: Task, run) -> int:
    """How many of the run's points a stimulus shows: up to its arrival in the success radius, as
    the project's observers see it (:func:`scdp.scoring.observed_path`); the motion after it is idle."""
    return len(cut_at_goal(task, run.path, run.goals, run.target))


def frame_points(n_points: int, point_s: float, fps: int) -> np.ndarray:
    """The path point shown by each frame of a motion of ``n_points`` points, ``point_s`` apart: one frame
    every 1/fps s of the motion, so the frame count, like the duration, follows the path length."""
    duration = (n_points - 1) * point_s
    times = np.arange(int(np.floor(duration * fps + 1e-9)) + 1) / fps
    return np.minimum(np.round(times / point_s).astype(int), n_points - 1)


def _frames(task: Task, run, folder: Path, point_s: float, fps: int) -> tuple[View, str]:
    """Write a Block Reach run's observer-view frames into ``folder`` (``fps`` per second of its motion
    played ``point_s`` per point); the page's view of it, and how the frames draw the arm."""
    env = task.make_env()
    env.reset(seed=0, options={"goals": run.goals, "target": int(run.target)})
    for k in range(len(run.goals)):
        env.model.geom(f"block{k}").rgba = NEUTRAL_BLOCK_RGBA
    camera = observer_camera(*FRAME_SIZE)
    n = shown_length(task, run)
    states = np.asarray(run.states)[:n]
    frames, _ = render_poses(env, states[frame_points(n, point_s, fps)], camera)
    names = []
    for rgb in frames:
        ok, data = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
        if not ok:
            raise ScdpError("frames", "could not encode a frame")
        name = hashlib.sha256(data.tobytes()).hexdigest()[:24] + ".jpg"  # opaque: tells nothing of the stimulus
        (folder / name).write_bytes(data.tobytes())
        names.append(name)
    path_px, _ = camera.project(np.asarray(run.path)[:n])
    goals_px, _ = camera.project(np.asarray(run.goals))
    return View("camera", camera.width, camera.height, tuple(names), tuple(map(tuple, np.round(path_px, 1).tolist())),
                tuple(map(tuple, np.round(goals_px, 1).tolist()))), arm_words(env.model)


def _stimulus(task: Task, run, *, kind: str, method: str, scene_set: str, index: int, view: View) -> Stimulus:
    return Stimulus(kind=kind, method=method, scene_set=scene_set, scene_index=index,
                    goals=np.round(np.asarray(run.goals), 4).tolist(), target=int(run.target),
                    path=np.round(np.asarray(run.path)[:shown_length(task, run)], 4).tolist(), success=bool(run.success),
                    styles=list(run.styles), view=view)


def make_study(task: Task, checkpoints, out, config: StudyConfig, *, force: bool = False, command: str = "") -> Study:
    """Roll ``config.methods`` out on the study's scenes from ``checkpoints`` and write the study
    folder ``out`` (refused when it exists, unless ``force``). Returns what ``study.json`` holds."""
    out = check_output_path(out, force=force)
    checkpoints = Path(checkpoints)
    config = replace(config, salt=config.salt or secrets.token_hex(16))  # a secret of its own unless given
    seed = config.stream_seed  # every stimulus stream: the seed mixed with the salt, never served
    planners = {m: load_method(m, checkpoints, task) for m in config.methods}
    n_goals = trained_goal_count(planners.values()) or 2  # the scene encoder's count; 2 when none has one
    first = config.methods[0]
    sets, practice_scene = study_scenes(task, config.scenes_per_set, seed, n_goals)
    labelled = [(name, i, scene) for name in SETS for i, scene in enumerate(sets[name])]
    practice = ("practice", 0, practice_scene)
    config = replace(config, completion_code=config.completion_code or _code(),
                     declined_code=config.declined_code or _code(), screened_code=config.screened_code or _code())
    stimuli, runs = {}, {}
    with atomic_path(out, directory=True) as tmp:
        frames = tmp / "frames"
        frames.mkdir()
        for method, planner in tqdm(planners.items(), desc=f"study {task.name}", unit="method"):
            jobs = [(MAIN, *x) for x in labelled] + ([(PRACTICE, *practice)] if method == first else [])
            done = rollout(task, planner, [scene for *_, scene in jobs], seeds=[scene_seed(seed, name, i) for _, name, i, _ in jobs])
            runs.update({(kind, name, i, method): run for (kind, name, i, _), run in zip(jobs, done)})
        # one speed for every motion: the median main motion lasts duration_s (Study.point_s)
        point_s = point_seconds(config.duration_s, [shown_length(task, r) for (kind, *_), r in runs.items() if kind == MAIN])
        arm_drawn = ""
        for (kind, name, i, method), run in tqdm(runs.items(), desc="frames" if task.name == "block_reach" else "stimuli",
                                                 unit="stimulus", disable=task.name != "block_reach"):
            view, arm_drawn = (_frames(task, run, frames, point_s, frame_rate(config.fps, point_s)) if task.name == "block_reach"
                               else (View("top"), ""))
            stimuli[stimulus_id(kind, name, i, method)] = _stimulus(task, run, kind=kind, method=method, scene_set=name,
                                                                    index=i, view=view)
        study = Study(task=task_reference(task), goals=n_goals, config=config, success_radius=float(task.success_radius),
                      stimuli=stimuli, command=command,
                      checkpoints=str(checkpoints), scdp_version=__version__, arm_drawn=arm_drawn,
                      checkpoint_sha256={str(p.relative_to(checkpoints)): file_sha256(p)
                                         for p in sorted(checkpoints.rglob("*.safetensors"))},
                      scenes=[{"scene_set": name, "scene_index": i, "goals": np.round(g, 4).tolist(), "target": int(t),
                               "seed": scene_seed(seed, name, i)}
                              for name, i, (g, t) in labelled + [practice]])
        study = replace(study, page_weight_mb=round(page_weight(study, frames) / 2**20, 2))
        write_json(tmp / STUDY_FILE, study.to_dict())
    return study


def _code() -> str:
    return secrets.token_hex(4).upper()


def page_weight(study: Study, frames: Path) -> int:
    """Bytes of frames one participant downloads (the largest Latin-square row; 0 for a top view): each frame
    once, as the page fetches a frame by its name once."""
    def weight(stimuli) -> int:
        return sum((frames / f).stat().st_size for f in {f for sid in stimuli for f in study.stimuli[sid].view.frames})
    shared = [sid for sid, stim in study.stimuli.items() if stim.kind != MAIN]
    return max(weight(shared + main_stimuli(study, row)) for row in range(len(study.config.methods)))


def read_study(folder) -> Study:
    """``study.json`` of a study folder, checked field by field (:meth:`Study.from_dict`)."""
    path = Path(folder) / STUDY_FILE
    if not path.is_file():
        raise ScdpError("--study", f"{folder} is not a study folder (no {STUDY_FILE}; make one with scdp study make)")
    try:
        study = json.loads(path.read_text())
    except ValueError as exc:
        raise ScdpError("--study", f"{path} is not valid JSON ({exc})") from None
    return Study.from_dict(study, str(path))
