"""How much a bot can learn from a study's design before it answers: button patterns and check scenes.

Regenerates: `results/study_checks.md`

    python benchmarks/study_checks.py --out results/study_checks.md

Four questions, each under the design scdp used before and the one it uses now (sections 1-3: no model, no
browser, seconds; section 4 makes a Navigation study from ``--run``'s checkpoints, about a minute):

1. **Button patterns.** A bot that never watches bets on where the target's button is, from the
   practice's answer (the page reveals it) and the earlier trials' buttons it could have inferred.
   Three bets: alternate from the practice, repeat the last button, and the other one than last
   time. Under the old design (the button cycles over positions from a random offset), under a
   shuffle balanced within the run, and under scdp's draw (:func:`scdp.study.design.target_buttons`).
2. **Check scenes.** The feature that told the old attention checks apart (goal separation over
   the mean start-to-goal distance): the best single threshold's accuracy and the AUC between check
   scenes and main scenes, for the old pick (the most separated of 64 random scenes) and for
   today's checks (main trials drawn per participant: :func:`scdp.study.design.check_trials`).
3. **Channels to the target before the motion shows it** (issues 60 and 75), each bet under format 3 and
   today's format 7, on Navigation scenes of the study stream (format 3: with the generator's own paths, Bézier
   curves at the robot's step, :func:`scdp.scoring.reference_paths`, standing in for rollouts):

   - *fields*: format 3 sent the path's point count; the bet takes the goal whose distance from the
     start best matches the length it implies (today no count is sent: the bet has only the goals,
     and takes the farther one);
   - *seed table*: rebuild the study's scenes from the public code and seed 0 (today a secret salt
     is mixed into the streams, and a layout has no target of its own: it is drawn per participant);
   - *speed*: the on-screen speed at 10 % of the motion; format 3 played every motion in 6 s, so
     speed gave the length; today every motion plays at one speed;
   - *near/far*: always the farther goal, on main scenes and on checks (format 3: eq. 3's sets as
     drawn, where the ambiguous set leans to the nearer goal; today the target is a uniform draw per
     participant among a layout's goals: :func:`scdp.study.design.scene_targets`);
   - *checks across participants*: a bot that has taken one run per Latin-square row calls a trial a
     check when its scene was a check in a run it took (format 3: every run had the same checks, on
     scenes of their own; today a check is one of the participant's own main trials);
   - *memo* and *count*: a bot that kept where each scene's motion ended in one run bets it in the next
     (format 3 to 6: every participant saw every scene with the same target), and a bot bets the near/far
     rank a run has not used up (format 6 balanced them within each run).
4. **The "ahead" screen** (:mod:`scdp.study.screening`): how often it flags simulated honest people, a bot
   that knows every target, and the memo bot, under each reader it may compare with.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
import zlib
from dataclasses import replace
from pathlib import Path

import numpy as np

from scdp.cli import main as scdp_main
from scdp.data.scenes import ATTENTION as ATTENTION_STREAM
from scdp.data.scenes import STUDY, sample_scene, stream_rng
from scdp.evaluation.protocol import scene_sets
from scdp.io import write_text
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.scoring import reference_paths
from scdp.study.design import assignment, scene_key, stimulus_id, target_buttons
from scdp.study.make import read_study, study_scenes
from scdp.study.person import ParticipantModel
from scdp.study.power import Answers
from scdp.study.record import AHEAD_OBSERVERS, ANALYSED, CHECKS, MAIN, PRACTICE, Stimulus, Study, StudyConfig, View
from scdp.study.screening import ahead, unreadable
from scdp.tasks import get_task

TRIALS = 15  # a run: 12 main trials (3 methods x 2 sets x 2 scenes), 2 attention checks, 1 instructed check
PARTICIPANTS = 2000


def _study(goals: int) -> Study:
    """A study record with TRIALS + 1 stimuli (only their ids matter to the button draw)."""
    def stim(i):
        return Stimulus("main", "dp", AMBIGUOUS, i, [[0, 0]] * goals, 0, [[0, 0], [1, 1]], True, [], View("top"))
    return Study(task="navigation", goals=goals, config=StudyConfig(methods=("dp", "ld", "scdp"), scenes_per_set=3),
                 success_radius=0.15, stimuli={f"s{i:02d}": stim(i) for i in range(TRIALS + 1)})


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
            out[n] = [buttons[scene_key(study, s)] for s in order]
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


def channel_bets(task, studies: int) -> list[tuple[str, float, float, float]]:
    """(bet, hit rate under format 3, under format 7, half-width of format 7's 95 % interval) for each
    channel of the module docstring; the interval resamples studies (a study's scenes are not independent)."""
    start = task.start_point
    per_study = {k: ([], []) for k in ("fields", "seed", "speed", "far", "far_checks", "known", "memo", "count")}
    for seed in range(studies):
        hits = {k: ([], []) for k in ("fields", "seed", "speed", "far")}
        for goals, target in (s for name in (AMBIGUOUS, CLEAR) for s in scene_sets(task, 6, seed, n_goals=2, stream=STUDY)[name]):
            goals = np.asarray(goals)  # format 3: eq. 3's sets as drawn, one target per scene, its path's count sent
            path = reference_paths(task, goals, target, 1, seed)[0]
            length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
            distance = np.linalg.norm(goals - start, axis=1)
            guess = int(np.argmin(np.abs(distance - length)))  # the length the count (or the speed over 6 s) gives
            for k, hit in (("far", int(np.argmax(distance)) == target), ("fields", guess == target),
                           ("speed", guess == target), ("seed", True)):  # format 3: the seed rebuilt the study itself
                hits[k][0].append(hit)
        salted = scene_study(task, int(np.random.default_rng([seed, 59]).integers(2**62)))  # format 7: salt, targets per run
        public, _ = study_scenes(task, 6, seed, 2)  # what the public code and the seed alone rebuild: layouts, no target
        table = {tuple(np.round(np.asarray(g), 4).ravel()) for name in (AMBIGUOUS, CLEAR) for g in public[name]}
        for goals, target in (s for part in check_split(salted, 20) for s in part):  # 20 runs, checks and all
            assert tuple(np.round(goals, 4).ravel()) not in table  # the salt: no served layout is in the seed's table
            far = int(np.argmax(np.linalg.norm(goals - start, axis=1)))
            for k in ("far", "fields", "speed", "seed"):  # no count, one speed, no table (nor a target per layout)
                hits[k][1].append(far == target)
        for k, (old, new) in hits.items():
            per_study[k][0].append(np.mean(old))
            per_study[k][1].append(np.mean(new))
        study = scene_study(task, seed)
        checks = check_split(study, 20)[0]
        per_study["far_checks"][0].append(np.nan)
        per_study["far_checks"][1].append(np.mean([int(np.argmax(np.linalg.norm(g - start, axis=1))) == t for g, t in checks]))
        per_study["known"][0].append(1.0)  # format 3: every run had the same checks, never a main scene
        per_study["known"][1].append(checks_known(study, bots=20))
        memo, count = run_to_run_bets(study, participants=20, start=np.asarray(start, dtype=np.float64)[:2])
        for k, rate in (("memo", memo), ("count", count)):
            per_study[k][0].append(1.0 if k == "memo" else np.nan)  # format 3: every run the same targets
            per_study[k][1].append(rate)
    names = {"fields": "fields: the path's point count", "seed": "seed table: scenes rebuilt from seed 0",
             "speed": "speed at 10 % of the motion", "far": "near/far: the farther goal, main scenes",
             "far_checks": "near/far: the farther goal, checks",
             "known": "checks known after one run per row (balanced accuracy)",
             "memo": "memo: each scene's target as the run before ended",
             "count": "count: the near/far rank the run has not used up"}
    rows = []
    for k, (old, new) in per_study.items():
        new = np.asarray(new)
        rows.append((names[k], float(np.mean(old)), float(np.mean(new)), float(1.96 * np.std(new, ddof=1) / np.sqrt(len(new)))))
    return rows


def run_to_run_bets(study: Study, participants: int, start: np.ndarray) -> tuple[float, float]:
    """Two bets across and within runs (issue 75), over the main trials of ``participants`` consecutive runs:

    * memo: a bot that took run n keeps where each scene's motion ended (the target, found again in run n+1 by
      its goals, mirrored or not) and bets it in run n+1; its hit rate over run n+1's main trials;
    * count: within one run, the bot bets the target is the farther goal (from ``start``) while the run has
      shown fewer farther than nearer targets, the nearer one while it has shown more, the farther one on a tie.
    """
    memo, count, kept = [], [], {}
    for n in range(participants):
        near_far = [0, 0]
        for t in assignment(study, n)[1:]:
            stim = study.stimuli[t.stimulus]
            goals = np.asarray(stim.goals, dtype=np.float64)
            scene, far = (stim.scene_set, stim.scene_index), int(np.argmax(np.linalg.norm(goals - start, axis=1)))
            if n > 0 and scene in kept:
                memo.append(kept[scene] == stim.target)
            kept[scene] = stim.target  # where this run's motion ended (the stand-in paths reach their targets)
            bet_far = near_far[1] <= near_far[0]
            count.append(bet_far == (far == stim.target))
            near_far[int(far == stim.target)] += 1
    return float(np.mean(memo)), float(np.mean(count))


def scene_study(task, seed: int) -> Study:
    """A study record on the study stream's layouts of ``seed`` (3 methods, 6 + 6 scenes each toward both goals,
    2 attention and 1 instructed checks): what the design draws from; the paths are stand-ins (only the goals
    and the target matter)."""
    config = StudyConfig(methods=("dp", "ld", "scdp"), scenes_per_set=6, attention=2, instructed=1, seed=seed)
    sets, _ = study_scenes(task, 6, seed, 2)
    stimuli = {stimulus_id(MAIN, name, i, t, m): Stimulus(MAIN, m, name, i, np.asarray(g).tolist(), t,
                                                           [[0, 0], np.asarray(g)[t].tolist()], True, [], View("top"))
               for name in (AMBIGUOUS, CLEAR) for i, g in enumerate(sets[name]) for t in (0, 1) for m in config.methods}
    stimuli["practice"] = Stimulus(PRACTICE, "dp", "practice", 0, [[0, 0]] * 2, 0, [[0, 0], [1, 1]], True, [], View("top"))
    return Study(task="navigation", goals=2, config=config, success_radius=0.15, stimuli=stimuli)


def ahead_rates(study: Study, participants: int) -> list[tuple]:
    """For each reader the "ahead" screen may compare with (:data:`scdp.study.record.AHEAD_OBSERVERS`): how many of
    the study's main stimuli it cannot read at ``ahead_at``, the trials a participant is tested on, and the share of
    ``participants`` runs flagged among simulated honest people (noise 0.5, reacting 0.5 s or 0.3 s behind; no
    noise) and two bots that pick at 0.32 s (past the early rule): one that knows every target, and the memo bot
    (the targets the run before ended at, today's design)."""
    people = {"honest (noise 0.5, 0.5 s)": ParticipantModel(), "honest, fast (noise 0.5, 0.3 s)": ParticipantModel(delay_s=0.3),
              "honest, no noise (0.5 s)": ParticipantModel(noise=0.0)}
    rows = []
    for observer in AHEAD_OBSERVERS:
        judged = replace(study, config=replace(study.config, screening=replace(study.config.screening, ahead_observer=observer)))
        hidden = unreadable(judged, judged.ids(MAIN))
        runs = [[t for t in assignment(judged, n) if t.kind in ANALYSED] for n in range(participants + 1)]
        p_values, tested = [], []  # per group, every run's p
        for model in people.values():
            answers, rng = Answers(judged, model), np.random.default_rng(0)
            group = []
            for n in range(1, participants + 1):
                rows_n = [{"stimulus": t.stimulus, "events": answers(t.stimulus, rng)} for t in runs[n]]
                right, trials, p = ahead(judged, rows_n, hidden)
                group.append(p)
                tested.append(trials)
            p_values.append(group)
        kept = [{scene_key(judged, t.stimulus): judged.stimuli[t.stimulus].target for t in assignment(judged, n)[1:]}
                for n in range(participants + 1)]  # every main trial's ending, the instructed check's too
        for bot in ("key", "memo"):
            group = []
            for n in range(1, participants + 1):
                rows_n = []
                for t in runs[n]:
                    stim = judged.stimuli[t.stimulus]
                    goal = stim.target if bot == "key" else kept[n - 1][scene_key(judged, t.stimulus)]
                    rows_n.append({"stimulus": t.stimulus, "events": [{"t": 0.32 / judged.motion_s(t.stimulus), "s": 0.32,
                                                                        "goal": goal}]})
                group.append(ahead(judged, rows_n, hidden)[2])
            p_values.append(group)
        for alpha in (judged.config.screening.ahead_alpha, 0.05):
            rows.append((observer, alpha, len(hidden), len(judged.ids(MAIN)), float(np.mean(tested)),
                         *(float(np.mean(np.asarray(g) < alpha)) for g in p_values)))
    return rows


def check_split(study: Study, participants: int) -> tuple[list, list]:
    """The scenes (goals, target) of ``participants`` runs' checks and of their other main trials."""
    checks, mains = [], []
    for n in range(participants):
        for t in assignment(study, n)[1:]:
            stim = study.stimuli[t.stimulus]
            (checks if t.kind in CHECKS else mains).append((np.asarray(stim.goals), stim.target))
    return checks, mains


def checks_known(study: Study, rows: int = 3, bots: int = 300) -> float:
    """Balanced accuracy of calling a trial a check when its scene was a check in one of ``rows``
    earlier runs (consecutive consent numbers, one per Latin-square row), under today's design."""
    hits, alarms = [], []
    for bot in range(bots):
        first = bot * (rows + 1)
        seen = {study.stimuli[t.stimulus].scene_set + str(study.stimuli[t.stimulus].scene_index)
                for n in range(first, first + rows) for t in assignment(study, n) if t.kind in CHECKS}
        for t in assignment(study, first + rows)[1:]:
            stim = study.stimuli[t.stimulus]
            (hits if t.kind in CHECKS else alarms).append(stim.scene_set + str(stim.scene_index) in seen)
    return float((np.mean(hits) + 1 - np.mean(alarms)) / 2)


def ahead_section(run: str, participants: int) -> list[str]:
    """Section 4: a Navigation study made from ``run``'s checkpoints (12 + 12 scenes) and the "ahead" screen's rates."""
    work = Path(tempfile.mkdtemp(prefix="scdp-study-checks-"))
    try:
        start = time.perf_counter()
        if scdp_main(["study", "make", "--task", "navigation", "--checkpoints", str(Path(run) / "navigation" / "checkpoints"),
                      "--scenes", "12", "--seed", "7", "--salt", "5eed", "--out", str(work / "study")]) != 0:
            raise SystemExit("scdp study make failed")
        study = read_study(work / "study")
        rows = ahead_rates(study, participants)
        minutes = (time.perf_counter() - start) / 60
    finally:
        shutil.rmtree(work, ignore_errors=True)
    rules = study.config.screening
    lines = ["", f"## 4. The \"ahead\" screen: right early where the motion does not tell ({participants} runs each; a "
             f"Navigation study of the committed models in `{run}`, 12 + 12 scenes, every one toward both goals; "
             f"{minutes:.1f} min)", "",
             f"A participant is excluded when, on the main trials whose motion the chosen observer cannot read at "
             f"{rules.ahead_at:.0%} of it ({rules.ahead_delay_s:g} s behind the motion, as a fast person reacts), the pick "
             f"standing there was the target more often than guessing allows (one-sided binomial p < α; the rule's α is "
             f"{rules.ahead_alpha:g}, 0.05 beside it). Shares of participants flagged; the honest people are the simulated "
             "person of scdp.study.person, offline; the bots pick at 0.32 s, past the early rule. The default reader is the "
             "path-length observer; the others are the free choice shown beside it.", "",
             "| reader | α | stimuli it cannot read | trials tested a run | " + " | ".join(
                 ("honest (noise 0.5, 0.5 s)", "honest, fast (noise 0.5, 0.3 s)", "honest, no noise (0.5 s)",
                  "bot that knows every target", "memo bot (today's design)")) + " |", "|---|---|---|---|---|---|---|---|---|"]
    for observer, alpha, hidden, total, tested, *rates in rows:
        lines.append(f"| {observer} | {alpha:g} | {hidden} of {total} | {tested:.1f} | " + " | ".join(f"{r:.3f}" for r in rates)
                     + " |")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="results/study_checks.md")
    p.add_argument("--run", default="results/cpu", help="a cpu reproduction whose navigation checkpoints section 4 uses")
    p.add_argument("--participants", type=int, default=1000, help="simulated runs per group in section 4 (default 1000)")
    p.add_argument("--studies", type=int, default=300,
                   help="study seeds (default 300: each format-5 bet's 95 %% interval within 0.02 of its rate)")
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
    old, new, mains, others = [], [], [], []
    for seed in range(args.studies):  # a study's main scenes (6 + 6), the old checks (3), 20 participants' checks
        old += old_checks(task, 3, seed)
        sets = scene_sets(task, 6, seed, n_goals=2, stream=STUDY)
        mains += sets[AMBIGUOUS] + sets[CLEAR]
        checks, rest = check_split(scene_study(task, seed), 20)
        new += checks
        others += rest
    lines += ["", f"## 2. Telling checks from main trials by their goals ({args.studies} Navigation studies: "
              f"old: {len(old)} checks against {len(mains)} main scenes; today: 20 participants each, {len(new)} checks "
              f"against {len(others)} other main trials; chance 0.500)", "",
              "Feature: goal separation over the mean start-to-goal distance, what the server sends before Start.", "",
              "| checks | best threshold's balanced accuracy | AUC |", "|---|---|---|"]
    for name, checks, rest in (("old: most separated of 64 random scenes", old, mains),
                               ("scdp: main trials drawn per participant (check_trials)", new, others)):
        best, auc = separability(checks, rest, start)
        lines.append(f"| {name} | {best:.3f} | {auc:.3f} |")
    lines += ["", f"## 3. Channels to the target before the motion shows it ({args.studies} Navigation studies of 12 main "
              "scenes, two goals; chance 0.500)", "",
              "The generator's paths at the robot's step stand in for rollouts (no model needed). Format 3 is the "
              "study before issue 60; format 7 today's, where every scene is shown toward a target drawn per "
              "participant (the module docstring says what each bet reads). Format 6 scored the memo bet 1.000 and "
              "the count bet 0.643 [0.640, 0.645] (results/study_checks.md at commit 83032cb).", "",
              "| bet | format 3 | format 7 | its 95 % interval |", "|---|---|---|---|"]
    for name, old_rate, new_rate, half in channel_bets(task, args.studies):
        lines.append(f"| {name} | {'–' if np.isnan(old_rate) else f'{old_rate:.3f}'} | {new_rate:.3f} | "
                     f"[{new_rate - half:.3f}, {new_rate + half:.3f}] |")
    lines += ahead_section(args.run, args.participants)
    write_text(Path(args.out), "\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
