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

from scdp import __version__, ambiguity
from scdp.content import file_sha256
from scdp.data.scenes import STUDY, scene_seed, stream_rng
from scdp.deploy.media import render_poses
from scdp.errors import ScdpError
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
MAX_LAYOUT_DRAWS = 100_000  # goal layouts study_scenes draws before it gives up on filling both sets
NEUTRAL_BLOCK_RGBA = (0.82, 0.82, 0.82, 1.0)  # every block alike: the page colours the goals per participant


def study_scenes(task: Task, n: int, seed: int, n_goals: int) -> tuple[dict, tuple]:
    """The study's ``n`` ambiguous and ``n`` clear goal layouts and its practice scene (a clear layout and a
    target), from the study stream. Every layout is shown toward each of its goals (a participant sees one:
    :func:`scdp.study.design.scene_targets`), so a layout joins a set only when eq. 3 gives that set for every
    one of its targets; layouts whose targets disagree are skipped. As the target is a uniform draw per
    participant, neither the goals nor the start predict it (each goal, the nearer and the farther alike, is
    the answer equally often)."""
    rng = stream_rng(STUDY, seed)
    sets: dict[str, list] = {name: [] for name in SETS}
    practice, targets = None, np.arange(n_goals)
    starts = np.repeat(np.asarray(task.start_point)[None], n_goals, axis=0)
    for _ in range(MAX_LAYOUT_DRAWS):
        if min(len(v) for v in sets.values()) == n and practice is not None:
            return sets, practice
        goals = task.sample_goals(rng, n_goals)
        flags = ambiguity.probabilistic_flags(starts, np.repeat(goals[None], n_goals, axis=0), targets, task.ambiguity)
        if flags.all() != flags.any():
            continue  # ambiguous toward one goal, clear toward another
        name = SETS[0] if flags.all() else SETS[1]
        if len(sets[name]) < n:
            sets[name].append(goals)
        elif name == SETS[1] and practice is None:
            practice = (goals, int(rng.integers(n_goals)))
    raise ScdpError("--scenes", f"{MAX_LAYOUT_DRAWS} layouts of {n_goals} goals gave {len(sets[SETS[0]])} ambiguous and "
                                f"{len(sets[SETS[1]])} clear for every target, {n} of each wanted: ask for fewer scenes")


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
    model = env.own_model()  # the colours change it
    for k in range(len(run.goals)):
        model.geom(f"block{k}").rgba = NEUTRAL_BLOCK_RGBA
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
    # every layout toward every goal (a participant sees one); the practice toward its own target
    labelled = [(name, i, (goals, t)) for name in SETS for i, goals in enumerate(sets[name]) for t in range(n_goals)]
    practice = ("practice", 0, practice_scene)
    config = replace(config, completion_code=config.completion_code or _code(),
                     declined_code=config.declined_code or _code(), screened_code=config.screened_code or _code())
    stimuli, runs = {}, {}
    with atomic_path(out, directory=True) as tmp:
        frames = tmp / "frames"
        frames.mkdir()
        for method, planner in tqdm(planners.items(), desc=f"study {task.name}", unit="method"):
            jobs = [(MAIN, *x) for x in labelled] + ([(PRACTICE, *practice)] if method == first else [])
            done = rollout(task, planner, [scene for *_, scene in jobs],
                           seeds=[stimulus_seed(seed, name, i, scene[1]) for _, name, i, scene in jobs])
            runs.update({(kind, name, i, scene[1], method): run for (kind, name, i, scene), run in zip(jobs, done)})
        # one speed for every motion: the median main motion lasts duration_s (Study.point_s)
        point_s = point_seconds(config.duration_s, [shown_length(task, r) for (kind, *_), r in runs.items() if kind == MAIN])
        arm_drawn = ""
        for (kind, name, i, target, method), run in tqdm(runs.items(), desc="frames" if task.name == "block_reach" else "stimuli",
                                                 unit="stimulus", disable=task.name != "block_reach"):
            view, arm_drawn = (_frames(task, run, frames, point_s, frame_rate(config.fps, point_s)) if task.name == "block_reach"
                               else (View("top"), ""))
            stimuli[stimulus_id(kind, name, i, target, method)] = _stimulus(task, run, kind=kind, method=method, scene_set=name,
                                                                    index=i, view=view)
        study = Study(task=task_reference(task), goals=n_goals, config=config, success_radius=float(task.success_radius),
                      stimuli=stimuli, command=command,
                      checkpoints=str(checkpoints), scdp_version=__version__, arm_drawn=arm_drawn,
                      checkpoint_sha256={str(p.relative_to(checkpoints)): file_sha256(p)
                                         for p in sorted(checkpoints.rglob("*.safetensors"))},
                      scenes=[{"scene_set": name, "scene_index": i, "goals": np.round(g, 4).tolist(), "target": int(t),
                               "seed": stimulus_seed(seed, name, i, t)}
                              for name, i, (g, t) in labelled + [practice]])
        study = replace(study, page_weight_mb=round(page_weight(study, frames) / 2**20, 2))
        write_json(tmp / STUDY_FILE, study.to_dict())
    return study


def _code() -> str:
    return secrets.token_hex(4).upper()


def stimulus_seed(seed: int, scene_set: str, index: int, target: int) -> int:
    """The rollout noise of a scene toward ``target``: the same for every method."""
    return scene_seed(seed, f"{scene_set}-{target}", index)


def page_weight(study: Study, frames: Path) -> int:
    """Bytes of frames one participant downloads (the largest run of a block of consent numbers, M x K, in which
    every scene is shown toward every goal; 0 for a top view): each frame once, as the page fetches a frame by
    its name once."""
    def weight(stimuli) -> int:
        return sum((frames / f).stat().st_size for f in {f for sid in stimuli for f in study.stimuli[sid].view.frames})
    shared = [sid for sid, stim in study.stimuli.items() if stim.kind != MAIN]
    methods = len(study.config.methods)
    return max(weight(shared + main_stimuli(study, n % methods, n)) for n in range(methods * study.goals))


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
