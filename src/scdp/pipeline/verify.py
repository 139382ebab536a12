"""``scdp verify``: does a run trained elsewhere support the committed verdicts?

Training the same preset on another processor gives other weights (floating point differs across
processors), so a user's own run cannot match the committed numbers digit for digit; what it can
do is support the same verdicts. :func:`verify` rolls out the run's models, with the committed
run's preset (its sampler, LD guidance, arbitration and methods), on fresh random scenes of an
evaluation seed neither run reported, judges the paper's claims, the style-effect targets and the
observer targets on them (:mod:`scdp.evaluation.claims`, :mod:`scdp.evaluation.targets`,
:mod:`scdp.evaluation.observer_targets`, with their 95 % intervals),
and sets each verdict beside the committed one. The six fixed layouts are left out (a few minutes
on 2 cores for the cpu preset).
"""

from __future__ import annotations

from pathlib import Path

from scdp.errors import ScdpError
from scdp.evaluation import claims, tables, targets
from scdp.evaluation.normalised import under
from scdp.evaluation.observation import measure_all
from scdp.evaluation.observer_targets import observer_targets
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.io import read_json
from scdp.keys import AMBIGUOUS, CLEAR, NORMALISATIONS, RANDOM, SCENE_NORMALISATION
from scdp.pipeline.evaluate import preset_planners
from scdp.pipeline.stages import demos_range
from scdp.presets import get_preset
from scdp.tasks import TASKS, get_task

VERIFY_SEED = 1234  # an evaluation seed no committed result reports


def _committed(against: Path) -> tuple[dict, dict]:
    try:
        judged, results = read_json(against / "claims.json"), read_json(against / "results.json")
    except (OSError, ValueError) as exc:
        raise ScdpError("--against", f"{against} holds no readable claims.json and results.json of a reproduction ({exc})") from None
    return judged, results


def _numbers(row: dict) -> str:
    """The numbers a verdict rests on, compact: an interval [mean, lo, hi] or the first values given."""
    numbers = row.get("numbers", {})
    for key in ("paired_difference", "paired_difference_vs_dp", "legible_minus_efficient_d_hat", "difference"):
        if isinstance(numbers.get(key), list):
            mean, lo, hi = numbers[key]
            return f"{key.replace('_', ' ')} {mean:+.3f} [{lo:+.3f}, {hi:+.3f}]"
    for key, sign in (("mean", "+"), ("share", "")):  # an observer target: a difference or a share
        if key in numbers:
            return f"{key} {numbers[key]:{sign}.3f} [{numbers['lo']:{sign}.3f}, {numbers['hi']:{sign}.3f}]"
    flat = {k: v for k, v in numbers.items() if isinstance(v, (int, float))}
    return ", ".join(f"{k} {v:.3f}" for k, v in list(flat.items())[:4])


def verify(run, against, *, scenes: int = 50, seed: int = VERIFY_SEED, device: str = "cpu") -> dict:
    """Judge ``run``'s models on fresh scenes with the preset of the committed run ``against``; one
    row per committed claim and target of the tasks ``run`` trained: the committed verdict, the
    run's, and the run's numbers."""
    run, against = Path(run), Path(against)
    committed, results = _committed(against)
    if scenes < 2:
        raise ScdpError("--scenes", f"at least 2 per scene set (a paired interval needs them), got {scenes}")
    names = [t for t in TASKS if (run / t / "checkpoints").is_dir()]
    if not names:
        raise ScdpError("run", f"{run} holds no <task>/checkpoints folder of a reproduction ({', '.join(TASKS)})")
    preset = get_preset(results.get("preset", "cpu"), results.get("overrides") or ())
    records = []
    for name in names:
        task = get_task(name)
        planners = preset_planners(preset, run / name / "checkpoints", task, device)
        sets = {k: v for k, v in scene_sets(task, scenes, seed).items() if k in (AMBIGUOUS, CLEAR)}
        for r in evaluate_methods(task, planners, sets, seed=seed):
            r.protocol = RANDOM
            records.append(r)
    ranges = {name: found for name in names if (found := demos_range(run / name, keep=False)) is not None}
    measured = measure_all(records)
    rows = []
    for normalisation in NORMALISATIONS:
        theirs = committed if normalisation == SCENE_NORMALISATION else committed.get(normalisation)
        if not theirs or (normalisation != SCENE_NORMALISATION and set(names) - set(ranges)):
            continue  # the committed run or this one cannot be read over its training data
        mine = under(records, normalisation, ranges)
        seen = {o: m.read_through(records, mine) for o, m in measured.items()}
        own = claims.claims(tables.summaries(mine), records=mine) + targets.targets(mine) + observer_targets(mine, seen)
        rows += _rows(theirs, {(r["task"], r.get("claim", r.get("target"))): r for r in own}, names, normalisation)
    return {"run": str(run), "against": str(against), "preset": preset.name, "scenes_per_set": scenes, "seed": seed,
            "tasks": names, "normalisation_ranges": {k: v.to_dict() for k, v in ranges.items()}, "rows": rows,
            "agree": sum(r["run"] == r["committed"] for r in rows), "total": len(rows)}


def _rows(committed: dict, mine: dict, names: list[str], normalisation: str) -> list[dict]:
    """One row per committed claim or target (random-scene models, layouts aside) of one normalisation."""
    rows = []
    for r in committed.get("claims", []) + committed.get("targets", []) + committed.get("observer_targets", []):
        name = r.get("claim", r.get("target"))
        if r["task"] not in names or r.get("protocol", "random") != "random" or "layouts_" in name:
            continue  # the layouts are not rolled out here
        theirs = mine.get((r["task"], name))
        rows.append({"task": r["task"], "normalisation": normalisation, "verdict": name, "committed": r["holds"],
                     "run": None if theirs is None else theirs["holds"], "run_numbers": None if theirs is None else theirs["numbers"],
                     "committed_numbers": r["numbers"], "summary": "" if theirs is None else _numbers(theirs)})
    return rows


def verify_markdown(report: dict) -> str:
    """The verdicts side by side, a line per committed claim or target."""
    lines = [f"{report['run']} against {report['against']} ({report['preset']} preset; {report['scenes_per_set']} ambiguous + "
             f"{report['scenes_per_set']} clear fresh scenes per task, evaluation seed {report['seed']}): "
             f"{report['agree']} of {report['total']} verdicts agree", "",
             "D̂, Ê per scene, and over each run's own training demonstrations (`dataset`: the committed run's verdicts "
             "over its training data, this run's over its own).", "",
             "| task | normalisation | verdict | committed | this run | this run's numbers |", "|---|---|---|---|---|---|"]
    word = {True: "holds", False: "missed", None: "not judged"}
    for r in report["rows"]:
        mark = "" if r["run"] == r["committed"] else " **(differs)**"
        lines.append(f"| {r['task']} | {r.get('normalisation', 'scene')} | {r['verdict']} "
                     f"| {word[r['committed']]} | {word[r['run']]}{mark} | {r['summary']} |")
    return "\n".join(lines) + "\n"
