"""How much a bot can learn from a study's design before it answers: button patterns and check scenes.

    python benchmarks/study_checks.py --out results/study_checks.md

Two questions, each under the design scdp used before and the one it uses now (no model, no
browser; seconds):

1. **Button patterns.** A bot that never watches bets on where the target's button is, from the
   practice's answer (the page reveals it) and the earlier trials' buttons it could have inferred.
   Three bets: alternate from the practice, repeat the last button, and the other one than last
   time. Under the old design (the button cycles over positions from a random offset), under a
   shuffle balanced within the run, and under scdp's draw (:func:`scdp.study.design.target_buttons`).
2. **Check scenes.** The feature that told the old attention checks apart (goal separation over
   the mean start-to-goal distance): the best single threshold's accuracy and the AUC between check
   scenes and main scenes, for the old pick (the most separated of 64 random scenes) and for
   :func:`scdp.study.make.check_scenes` (drawn like the main scenes).
3. **Channels to the target before the motion shows it** (issue 60), each bet under format 3 and
   format 4, on Navigation scenes of the study stream with the generator's own paths (Bézier curves
   at the robot's step, :func:`scdp.scoring.reference_paths`) standing in for rollouts:

   - *fields*: format 3 sent the path's point count; the bet takes the goal whose distance from the
     start best matches the length it implies (format 4 sends no count: the bet has only the goals,
     and takes the farther one);
   - *seed table*: rebuild the study's scenes from the public code and seed 0 (format 4 mixes a
     secret salt into the streams);
   - *speed*: the on-screen speed at 10 % of the motion; format 3 played every motion in 6 s, so
     speed gave the length; format 4 plays every motion at one speed;
   - *near/far*: always the farther goal, on main scenes and on checks;
   - *checks across participants*: a bot that has taken one run per Latin-square row calls a trial a
     check when its goals were a check in a run it took (format 3: every run had the same checks).
"""

from __future__ import annotations

import argparse
import sys
import zlib
from pathlib import Path

import numpy as np

from scdp.data.scenes import ATTENTION as ATTENTION_STREAM
from scdp.data.scenes import STUDY, sample_scene, stream_rng
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.scoring import reference_paths
from scdp.study.design import check_stimuli, target_buttons
from scdp.study.make import CHECK_POOL, check_scenes
from scdp.study.record import ATTENTION, INSTRUCTED, Stimulus, Study, StudyConfig, View
from scdp.tasks import get_task

TRIALS = 15  # a run: 12 main trials (3 methods x 2 sets x 2 scenes), 2 attention checks, 1 instructed check
PARTICIPANTS = 2000


def _study(goals: int) -> Study:
    """A study record with TRIALS + 1 stimuli (only their ids matter to the button draw)."""
    stim = Stimulus("main", "dp", AMBIGUOUS, 0, [[0, 0]] * goals, 0, [[0, 0], [1, 1]], True, [], View("top"))
    return Study(task="navigation", goals=goals, config=StudyConfig(methods=("dp", "ld", "scdp"), scenes_per_set=3),
                 stimuli={f"s{i:02d}": stim for i in range(TRIALS + 1)})


def runs(design: str, goals: int = 2) -> np.ndarray:
    """(PARTICIPANTS, 1 + TRIALS) target buttons: the practice, then the trials in run order."""
    out = np.zeros((PARTICIPANTS, TRIALS + 1), dtype=int)
    study = _study(goals)
    for n in range(PARTICIPANTS):
        rng = np.random.default_rng([zlib.crc32(design.encode()), n])
        if design == "old: cycle from a random offset":
            out[n] = (rng.integers(goals) + np.arange(TRIALS + 1)) % goals
        elif design == "a shuffle balanced within the run":
            out[n, 0] = rng.integers(goals)
            out[n, 1:] = rng.permutation(np.resize(np.arange(goals), TRIALS))
        else:  # scdp's draw; the run order is a shuffle of the stimuli
            buttons = target_buttons(study, n)
            order = ["s00"] + [f"s{i:02d}" for i in 1 + rng.permutation(TRIALS)]
            out[n] = [buttons[s] for s in order]
    return out


def bets(positions: np.ndarray) -> dict[str, float]:
    """Hit rates over the trials after the practice (two buttons)."""
    practice, rest = positions[:, :1], positions[:, 1:]
    previous = np.concatenate([practice, rest[:, :-1]], axis=1)
    alternate = (1 - practice + np.arange(TRIALS)) % 2
    return {"alternate from the practice": float(np.mean(alternate == rest)),
            "repeat the last button": float(np.mean(previous == rest)),
            "the other button than last time": float(np.mean(previous != rest))}


def separability(checks: list, mains: list, start: np.ndarray) -> tuple[float, float]:
    def feature(scene):
        goals, _ = scene
        return float(np.linalg.norm(goals[0] - goals[1]) / np.mean(np.linalg.norm(goals - start, axis=1)))
    c, m = np.array([feature(s) for s in checks]), np.array([feature(s) for s in mains])
    values, labels = np.r_[c, m], np.r_[np.ones(len(c)), np.zeros(len(m))]
    w = np.where(labels == 1, 0.5 / len(c), 0.5 / len(m))  # balanced accuracy
    best = max(max(np.sum(w * ((values > t) == labels)), np.sum(w * ((values <= t) == labels))) for t in values)
    return float(best), float(np.mean(c[:, None] > m[None, :]))


def old_checks(task, count: int, seed: int) -> list:
    """The old pick: the `count` scenes whose target is most separated in angle from another goal, of 64."""
    rng = stream_rng(ATTENTION_STREAM, seed)
    start = task.start_point[:2]

    def angle(scene):
        goals, target = scene
        d = goals[:, :2] - start
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return min(np.arccos(np.clip(d[target] @ d[k], -1, 1)) for k in range(len(goals)) if k != target)
    candidates = [sample_scene(task, rng, 2) for _ in range(64)]
    return sorted(candidates, key=lambda s: -angle(s))[:count]


def channel_bets(task, studies: int) -> list[tuple[str, float, float]]:
    """(bet, hit rate under format 3, under format 4) for each channel of the module docstring."""
    start = task.start_point
    rows, fields, speed, rebuilt, farther = [], ([], []), ([], []), ([], []), []
    for seed in range(studies):
        sets = scene_sets(task, 6, seed, n_goals=2, stream=STUDY)
        salted = scene_sets(task, 6, int(np.random.default_rng([seed, 59]).integers(2**62)), n_goals=2, stream=STUDY)
        for name in (AMBIGUOUS, CLEAR):
            for (goals, target), (_, other_target) in zip(sets[name], salted[name]):
                goals = np.asarray(goals)
                path = reference_paths(task, goals, target, 1, seed)[0]
                length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
                distance = np.linalg.norm(goals - start, axis=1)
                far = int(np.argmax(distance))
                farther.append(far == target)
                # fields: the point count gives the length (format 3); format 4 sends none: the farther goal
                fields[0].append(int(np.argmin(np.abs(distance - length))) == target)
                fields[1].append(far == target)
                # speed at 10 %: format 3's 6 s gives length / 6; format 4's one speed gives nothing
                shown = length / 6.0
                speed[0].append(int(np.argmin(np.abs(distance / 6.0 - shown))) == target)
                speed[1].append(far == target)
                # the seed table: seed 0's scenes rebuilt, against the study's own (unsalted / salted)
                rebuilt[0].append(True)  # format 3: the public code and seed 0 give the study's own scenes
                rebuilt[1].append(target == other_target)
    rows += [("fields: the path's point count", float(np.mean(fields[0])), float(np.mean(fields[1]))),
             ("seed table: scenes rebuilt from seed 0", float(np.mean(rebuilt[0])), float(np.mean(rebuilt[1]))),
             ("speed at 10 % of the motion", float(np.mean(speed[0])), float(np.mean(speed[1]))),
             ("near/far: the farther goal, main scenes", float(np.mean(farther)), float(np.mean(farther)))]
    checks = check_scenes(task, 2 * studies, 0, 2)
    near_far = [int(np.argmax(np.linalg.norm(np.asarray(g) - start, axis=1))) == t for g, t in checks]
    rows.append(("near/far: the farther goal, checks", float("nan"), float(np.mean(near_far))))
    rows.append(("checks known after one run per row (balanced accuracy)", 1.0, checks_known()))
    return rows


def checks_known(rows: int = 3, runs: int = 2000) -> float:
    """Balanced accuracy of calling a trial a check when its scene was a check in one of ``rows`` earlier
    runs, under scdp's per-participant draw from pools of CHECK_POOL scenes per check (format 3: 1.0)."""
    config = StudyConfig(methods=("dp", "ld", "scdp"), scenes_per_set=3, attention=2, instructed=1)
    stim = Stimulus(ATTENTION, "dp", "attention", 0, [[0, 0]] * 2, 0, [[0, 0], [1, 1]], True, [], View("top"))
    stimuli = {f"{kind}-{kind}-{j:03d}-{m}": Stimulus(kind, m, kind, j, stim.goals, 0, stim.path, True, [], View("top"))
               for kind, n in ((ATTENTION, CHECK_POOL * 2), (INSTRUCTED, CHECK_POOL)) for j in range(n)
               for m in config.methods}
    study = Study(task="navigation", goals=2, config=config, stimuli=stimuli)
    hits = []
    for r in range(runs):
        rng = np.random.default_rng([r, 60])
        seen = {study.stimuli[s].scene_index * 2 + (study.stimuli[s].kind == INSTRUCTED)
                for _ in range(rows) for s in check_stimuli(study, rng)}
        now = [study.stimuli[s].scene_index * 2 + (study.stimuli[s].kind == INSTRUCTED) for s in check_stimuli(study, rng)]
        hits += [k in seen for k in now]
    recall = float(np.mean(hits))
    return (recall + 1.0) / 2  # a main trial's scene is never a check's: no false alarms


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="results/study_checks.md")
    p.add_argument("--studies", type=int, default=100, help="study seeds for the check scenes (default 100)")
    args = p.parse_args(argv)
    command = " ".join(["python", "benchmarks/study_checks.py", *(argv if argv is not None else sys.argv[1:])])
    lines = ["# What a bot can learn from a study's design", "", f"`{command}`. docs/study.md says why it matters.", "",
             f"## 1. Betting on the target's button ({PARTICIPANTS} runs of {TRIALS} trials after a practice, "
             "two goals; chance 0.500)", "",
             "| design | " + " | ".join(bets(runs("scdp"))) + " |", "|---|---|---|---|"]
    for design in ("old: cycle from a random offset", "a shuffle balanced within the run", "scdp: target_buttons"):
        lines.append(f"| {design} | " + " | ".join(f"{v:.3f}" for v in bets(runs(design)).values()) + " |")
    task = get_task("navigation")
    start = task.start_point
    old, new, mains = [], [], []
    for seed in range(args.studies):  # a study's checks (3) and main scenes (6 + 6), per seed
        old += old_checks(task, 3, seed)
        new += check_scenes(task, 3, seed, 2)
        sets = scene_sets(task, 6, seed, n_goals=2, stream=STUDY)
        mains += sets[AMBIGUOUS] + sets[CLEAR]
    lines += ["", f"## 2. Telling checks from main trials by their goals ({args.studies} Navigation studies: "
              f"{len(new)} checks, {len(mains)} main scenes; chance 0.500)", "",
              "Feature: goal separation over the mean start-to-goal distance, what the server sends before Start.", "",
              "| checks | best threshold's balanced accuracy | AUC |", "|---|---|---|"]
    for name, checks in (("old: most separated of 64 random scenes", old), ("scdp: check_scenes, drawn like the main ones", new)):
        best, auc = separability(checks, mains, start)
        lines.append(f"| {name} | {best:.3f} | {auc:.3f} |")
    lines += ["", f"## 3. Channels to the target before the motion shows it ({args.studies} Navigation studies of 12 main "
              "scenes, two goals; chance 0.500)", "",
              "The generator's paths at the robot's step stand in for rollouts (no model needed). Format 3 is the "
              "study before issue 60, format 4 today's (the module docstring says what each bet reads).", "",
              "| bet | format 3 | format 4 |", "|---|---|---|"]
    for name, old_rate, new_rate in channel_bets(task, args.studies):
        lines.append(f"| {name} | {'–' if np.isnan(old_rate) else f'{old_rate:.3f}'} | {new_rate:.3f} |")
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
