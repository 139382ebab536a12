"""Who the analysis counts, and why each other participant is left out.

The rules are the study's :class:`~scdp.study.record.Screening`, written into ``study.json`` by
``scdp study make`` before any data exist. A participant is left out, with every reason that applies:

* ``screened out``: failed the comprehension check after the instructions (never saw a trial);
* ``unfinished``: did not confirm every trial and give the end-of-study ratings;
* ``attention``: answered fewer than ``min_attention`` of the attention checks correctly;
* ``instructed``: followed fewer than ``min_instructed`` of the instructed-response checks
  ("whatever the robot did, choose the red goal"), the kind participant platforms accept as
  grounds for rejecting a submission;
* ``away``: the page was hidden (another tab) or lost focus more than ``max_away`` times while a
  motion played, over the whole study;
* ``capped``: picks were refused (over the study's cap per trial, or faster than a person clicks)
  in more than ``max_capped`` trials;
* ``early``: in more than ``max_early`` of their trials the first pick came sooner than
  ``min_first_pick_s`` after Start on the server's clock, before anything was visible to decide on (a
  bot, or someone who answers before looking);
* ``ahead``: right too early. On the participant's main trials whose motion the ``ahead_observer`` (default the
  path-length observer; "any": none of the project's observers) cannot read at ``ahead_at`` of the motion,
  seeing it ``ahead_delay_s`` behind as a fast person does (:mod:`scdp.study.readable`), the pick standing there
  was the target more often than guessing among the K goals allows (one-sided binomial p below ``ahead_alpha``): an
  answer key, not the motion (a bot that kept another run's endings, or knows the targets);
* ``replays``: the page (re)loaded a trial while or after its motion played more than ``max_replays`` times;
* ``playback``: the page's motion ran behind the server's clock by more than ``max_lag`` of the
  motion (median over their picks): a slowed or stalled playback;
* ``too fast``: confirmed sooner than ``min_confirm_s`` after the motion ended (median over
  trials): no person reads and presses that fast;
* ``simulated``: a simulated participant (ID ``SIM-...``) in a database that also holds people;
  a database of simulated participants only is analysed as such, and labelled so.
"""

from __future__ import annotations

import csv
import io
from math import comb

import numpy as np

from scdp.study.design import SIMULATED_PREFIX, assignment
from scdp.study.readable import observer_correct, pick_at
from scdp.study.record import ANALYSED, ATTENTION, INSTRUCTED, Study

FIELDS = ("pid", "study_id", "session_id", "simulated", "number", "row", "finished", "main_answered", "accuracy",
          "attention", "instructed", "away", "capped", "early", "ahead", "ahead_p", "minutes", "replays", "lag",
          "confirm_s", "analysed", "reasons")


def is_simulated(pid: str) -> bool:
    return pid.startswith(SIMULATED_PREFIX)


def unreadable(study: Study, stimuli) -> set[str]:
    """The ``stimuli`` whose target the screening's ``ahead_observer`` cannot read at ``ahead_at`` of the motion,
    ``ahead_delay_s`` behind it."""
    rules, out = study.config.screening, set()
    for sid in sorted(set(stimuli)):
        reads = observer_correct(study, [sid], seconds=[rules.ahead_at * study.motion_s(sid)], delay_s=rules.ahead_delay_s)
        if not any(v[0, 0] for name, v in reads.items() if rules.ahead_observer in ("any", name)):
            out.add(sid)
    return out


def ahead(study: Study, main: list[dict], hidden: set[str]) -> tuple[int, int, float]:
    """(right, trials, p) of the "ahead" rule over a participant's ``main`` rows: on the trials of a ``hidden``
    stimulus, how often the pick standing at ``ahead_at`` of the motion was the target, and the chance of that
    many or more by guessing among the goals (binomial, 1 / K a trial)."""
    at = study.config.screening.ahead_at
    hits = [pick_at(r["events"], at) == study.stimuli[r["stimulus"]].target for r in main if r["stimulus"] in hidden]
    n, k, q = len(hits), int(sum(hits)), 1.0 / study.goals
    return k, n, float(sum(comb(n, j) * q**j * (1 - q) ** (n - j) for j in range(k, n + 1)))


def participant_table(study: Study, participants: list[dict], rows: list[dict]) -> list[dict]:
    """One dict per consented participant (:data:`FIELDS`), ``reasons`` empty when analysed."""
    rules = study.config.screening
    people = any(not is_simulated(p["pid"]) for p in participants)
    by_pid: dict[str, list[dict]] = {}
    for r in rows:
        by_pid.setdefault(r["pid"], []).append(r)
    hidden = unreadable(study, [r["stimulus"] for r in rows if r["kind"] in ANALYSED])
    out = []
    for p in participants:
        mine = by_pid.get(p["pid"], [])
        n_trials = len(assignment(study, p["number"], p["row"]))
        main = [r for r in mine if r["kind"] in ANALYSED]  # attention checks are main trials
        checks = [r for r in mine if r["kind"] == ATTENTION]
        told = [r for r in mine if r["kind"] == INSTRUCTED]
        lags = [e["t"] - e["client_t"] for r in mine for e in r["events"]]
        firsts = [min(e["s"] for e in r["events"]) for r in mine if r["events"]]  # the server's seconds after Start
        early = sum(t < rules.min_first_pick_s - 1e-9 for t in firsts)
        confirm = [r["confirmed"] - (r["played"] + study.motion_s(r["stimulus"])) for r in mine]
        last = max([r["confirmed"] for r in mine], default=p["consented"])
        right, hard, p_ahead = ahead(study, main, hidden)
        row = {"pid": p["pid"], "study_id": p["platform_study"], "session_id": p["platform_session"],
               "simulated": is_simulated(p["pid"]), "number": p["number"], "row": p["row"],
               "finished": p["completed"] is not None and len(mine) >= n_trials, "main_answered": len(main),
               "accuracy": float(np.mean([r["correct"] for r in main])) if main else None,
               "attention": f"{sum(r['correct'] for r in checks)}/{len(checks)}",
               "instructed": f"{sum(r['correct'] for r in told)}/{len(told)}",
               "away": int(sum(r["hidden"] + r["blurs"] for r in mine)),
               "capped": int(sum(r["refused"] > 0 for r in mine)),
               "early": f"{early}/{len(firsts)}", "ahead": f"{right}/{hard}", "ahead_p": round(p_ahead, 4),
               "minutes": round(((p["completed"] or last) - p["consented"]) / 60.0, 2),
               "replays": int(sum(r["replays"] for r in mine)),
               "lag": float(np.median(lags)) if lags else None,
               "confirm_s": float(np.median(confirm)) if confirm else None}
        reasons = []
        if p["screened_out"] is not None:
            reasons.append("screened out (failed the comprehension check)")
        elif not row["finished"]:
            rated = "" if p["completed"] is not None or len(mine) < n_trials else ", no ratings"
            reasons.append(f"unfinished ({len(mine)} of {n_trials} trials{rated})")
        if checks and sum(r["correct"] for r in checks) / len(checks) < rules.min_attention:
            reasons.append(f"attention ({row['attention']} checks correct, {rules.min_attention:.0%} required)")
        if told and sum(r["correct"] for r in told) / len(told) < rules.min_instructed:
            reasons.append(f"instructed ({row['instructed']} instructions followed, {rules.min_instructed:.0%} required)")
        if row["away"] > rules.max_away:
            reasons.append(f"away (the page was hidden or lost focus {row['away']} times during motions, at most "
                           f"{rules.max_away})")
        if row["capped"] > rules.max_capped:
            reasons.append(f"capped (picks refused in {row['capped']} trials: over the cap or too fast, at most "
                           f"{rules.max_capped})")
        if firsts and early / len(firsts) > rules.max_early:
            reasons.append(f"early (first pick within {rules.min_first_pick_s:g} s of Start, before anything was visible, "
                           f"in {row['early']} trials; at most {rules.max_early:.0%})")
        if p_ahead < rules.ahead_alpha:
            reasons.append(f"ahead (right at {rules.ahead_at:.0%} of the motion in {right} of {hard} trials that the "
                           f"{rules.ahead_observer} observer cannot read by then: p = {p_ahead:.4f} by guessing, below "
                           f"{rules.ahead_alpha:g})")
        if row["replays"] > rules.max_replays:
            reasons.append(f"replays ({row['replays']} reloads of a playing motion, at most {rules.max_replays})")
        if row["lag"] is not None and row["lag"] > rules.max_lag:
            reasons.append(f"playback (the page ran {row['lag']:.2f} of the motion behind the server, at most "
                           f"{rules.max_lag:.2f})")
        if row["confirm_s"] is not None and row["confirm_s"] < rules.min_confirm_s:
            reasons.append(f"too fast (confirmed {row['confirm_s']:.2f} s after the motion ended, at least "
                           f"{rules.min_confirm_s:.2f} s)")
        if row["simulated"] and people:
            reasons.append("simulated (the database also holds people; simulated answers never join theirs)")
        out.append({**row, "analysed": not reasons, "reasons": reasons})
    return out


def participants_csv(people: list[dict]) -> str:
    """The participant table as CSV (reasons joined by "; ")."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=FIELDS, lineterminator="\n")
    writer.writeheader()
    for p in people:
        writer.writerow({**p, "reasons": "; ".join(p["reasons"])})
    return buffer.getvalue()
