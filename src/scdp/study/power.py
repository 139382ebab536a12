"""``scdp study power``: how many participants a study needs, by simulation over its own design.

For each candidate number of participants N, ``replicates`` whole studies are simulated on the study's own
stimuli and design: participants 0..N-1 on their Latin-square rows (:func:`scdp.study.design.assignment`: the
scenes, methods, targets and checks each would get), each answering every main trial. Answers come

* from the simulated person (:class:`scdp.study.person.ParticipantModel`, the path-length observer with a
  reaction delay and a misjudgement per trial: what ``scdp study simulate`` puts through the page), or
* from pilot data (``pilot``): each trial's picks are drawn from the analysed pilot responses to the same
  stimulus (where it had none, to the same method on the same scene, whichever target; then on the same set; a
  pick of that response's target counts as a pick of this one's, and the other way round).

The screening rules the simulation can apply are applied (attention checks, the "ahead" rule, and ``dropout``:
a share of participants lost at random to the rest of them), and the analysed responses go through the
analysis's own crossed bootstrap. A replicate detects the difference when the interval of A - B on the scene
set excludes 0 in the claimed direction (A more legible than B: higher for accuracies, lower for ``t_kept``).
The power at N is the share of replicates that detect it; the recommended size is the smallest N of the grid
with power at least ``target``.
"""

from __future__ import annotations

import numpy as np

from scdp.errors import ScdpError
from scdp.evaluation.resampling import crossed_weights, percentile_interval, weighted_means
from scdp.study.analysis import correct_at_seconds, kept_time
from scdp.study.design import assignment
from scdp.study.person import ParticipantModel
from scdp.study.power_settings import PowerSettings
from scdp.study.quantities import LOWER_IS_BETTER
from scdp.study.readable import pick_at
from scdp.study.record import ANALYSED, ATTENTION, MAIN, Study
from scdp.study.screening import ahead, unreadable


def value(quantity: str, events: list[dict], target: int) -> float:
    """One response's ``quantity`` from its picks (as :func:`scdp.study.analysis.response_table` reads it)."""
    if quantity == "final":
        return float(events[-1]["goal"] == target)
    if quantity == "t_kept":
        return kept_time(events, target)
    if quantity.endswith("s"):
        return correct_at_seconds(events, target, float(quantity[len("correct_at_"):-1]))
    return float(pick_at(events, int(quantity[len("correct_at_"):]) / 100) == target)


class Answers:
    """The picks of a simulated participant's trial on a stimulus: from the person model (its noiseless sights
    computed once per stimulus) or drawn from pilot responses."""

    def __init__(self, study: Study, model: ParticipantModel, pilot: list[dict] | None = None):
        self.study, self.model, self.pool, self.sights = study, model, {}, {}
        for r in pilot or []:
            stim = study.stimuli[r["stimulus"]]
            for key in (r["stimulus"], (stim.method, stim.scene_set, stim.scene_index), (stim.method, stim.scene_set)):
                self.pool.setdefault(key, []).append((r["events"], stim.target))
        if pilot is not None and not self.pool:
            raise ScdpError("--pilot", "the database holds no analysed main response to draw pilot answers from")  # API use

    def __call__(self, sid: str, rng: np.random.Generator) -> list[dict]:
        stim = self.study.stimuli[sid]
        if self.pool:
            found = (self.pool.get(sid) or self.pool.get((stim.method, stim.scene_set, stim.scene_index))
                     or self.pool.get((stim.method, stim.scene_set)))
            if not found:
                raise ScdpError("--pilot", f"no pilot response to {stim.method} on a {stim.scene_set} scene")
            events, target = found[int(rng.integers(len(found)))]
            swap = {target: stim.target, stim.target: target}  # a pick of the pilot's target is one of this target
            return [{**e, "goal": swap.get(e["goal"], e["goal"])} for e in events]
        if sid not in self.sights:
            looks, beliefs = self.model.sights(stim.path, stim.goals, self.study.point_s)
            self.sights[sid] = (looks, beliefs, self.model.belief(stim.path, stim.goals))
        looks, beliefs, final = self.sights[sid]
        return self.model.picks(looks, beliefs, self.model.noise * rng.standard_normal(len(stim.goals)), final)


def simulated_study(study: Study, answers: Answers, count: int, dropout: float, hidden: set,
                    rng: np.random.Generator) -> tuple[list[dict], int]:
    """The analysed main responses of ``count`` simulated participants ({pid, stimulus, events}) and how many
    participants the attention, "ahead" and dropout rules left out."""
    rules, kept, excluded = study.config.screening, [], 0
    for number in range(count):
        rows = [{"pid": number, "stimulus": t.stimulus, "kind": t.kind, "events": answers(t.stimulus, rng)}
                for t in assignment(study, number, number % len(study.config.methods)) if t.kind in ANALYSED]
        checks = [r["events"][-1]["goal"] == study.stimuli[r["stimulus"]].target for r in rows if r["kind"] == ATTENTION]
        _, _, p_ahead = ahead(study, rows, hidden)
        if (checks and np.mean(checks) < rules.min_attention) or p_ahead < rules.ahead_alpha or rng.random() < dropout:
            excluded += 1
            continue
        kept += rows
    return kept, excluded


def detects(study: Study, rows: list[dict], settings: PowerSettings, seed: int) -> tuple[bool, float]:
    """(whether the crossed-bootstrap interval of A - B excludes 0 in the claimed direction, the difference)."""
    stim = [study.stimuli[r["stimulus"]] for r in rows]
    values = np.array([value(settings.quantity, r["events"], s.target) for r, s in zip(rows, stim)])
    in_set = np.array([s.scene_set == settings.scene_set for s in stim])
    ma = in_set & np.array([s.method == settings.a for s in stim])
    mb = in_set & np.array([s.method == settings.b for s in stim])
    if not ma.any() or not mb.any():
        return False, float("nan")
    weights = crossed_weights(np.array([r["pid"] for r in rows]), np.array([f"{s.scene_set}/{s.scene_index}" for s in stim]),
                              settings.samples, seed)
    lo, hi = percentile_interval(weighted_means(weights, values, ma) - weighted_means(weights, values, mb))
    difference = float(values[ma].mean() - values[mb].mean())
    return bool(hi < 0 if settings.quantity in LOWER_IS_BETTER else lo > 0), difference


def power(study: Study, settings: PowerSettings, model: ParticipantModel = ParticipantModel(), pilot=None,
          progress=None) -> dict:
    """The power at each size of ``settings.participants`` (with its 95 % Wilson interval over replicates), the
    mean difference and exclusions there, and the recommended size (None when no size of the grid reaches it)."""
    settings.check(study)
    answers = Answers(study, model, pilot)
    hidden = unreadable(study, study.ids(MAIN))
    rows = []
    for n in settings.participants:
        hits, diffs, lost = [], [], []
        for r in range(settings.replicates):
            rng = np.random.default_rng(np.random.SeedSequence([settings.seed, n, r]))
            kept, excluded = simulated_study(study, answers, n, settings.dropout, hidden, rng)
            hit, diff = detects(study, kept, settings, seed=int(rng.integers(2**31)))
            hits.append(hit)
            diffs.append(diff)
            lost.append(excluded)
            if progress:
                progress(1)
        rows.append({"participants": n, "power": float(np.mean(hits)), "power_ci": wilson(int(np.sum(hits)), len(hits)),
                     "difference": float(np.nanmean(diffs)), "excluded": float(np.mean(lost))})
    enough = [row["participants"] for row in rows if row["power"] >= settings.target]
    return {"settings": {**settings.__dict__, "participants": list(settings.participants)},
            "answers": "pilot responses" if pilot is not None else f"simulated person {model.__dict__}",
            "sizes": rows, "recommended": enough[0] if enough else None}


def wilson(hits: int, n: int, z: float = 1.96) -> list[float]:
    """The 95 % Wilson score interval of a proportion ``hits / n``."""
    p, centre = hits / n, (hits + z * z / 2) / (n + z * z)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return [float(centre - half), float(centre + half)]
