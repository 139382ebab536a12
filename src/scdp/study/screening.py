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

import numpy as np

from scdp.study.design import SIMULATED_PREFIX, assignment
from scdp.study.record import ANALYSED, ATTENTION, INSTRUCTED, Study

FIELDS = ("pid", "study_id", "session_id", "simulated", "number", "row", "finished", "main_answered", "accuracy",
          "attention", "instructed", "away", "capped", "early", "minutes", "replays", "lag", "confirm_s", "analysed", "reasons")


def is_simulated(pid: str) -> bool:
    return pid.startswith(SIMULATED_PREFIX)


def participant_table(study: Study, participants: list[dict], rows: list[dict]) -> list[dict]:
    """One dict per consented participant (:data:`FIELDS`), ``reasons`` empty when analysed."""
    rules = study.config.screening
    people = any(not is_simulated(p["pid"]) for p in participants)
    by_pid: dict[str, list[dict]] = {}
    for r in rows:
        by_pid.setdefault(r["pid"], []).append(r)
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
        row = {"pid": p["pid"], "study_id": p["platform_study"], "session_id": p["platform_session"],
               "simulated": is_simulated(p["pid"]), "number": p["number"], "row": p["row"],
               "finished": p["completed"] is not None and len(mine) >= n_trials, "main_answered": len(main),
               "accuracy": float(np.mean([r["correct"] for r in main])) if main else None,
               "attention": f"{sum(r['correct'] for r in checks)}/{len(checks)}",
               "instructed": f"{sum(r['correct'] for r in told)}/{len(told)}",
               "away": int(sum(r["hidden"] + r["blurs"] for r in mine)),
               "capped": int(sum(r["refused"] > 0 for r in mine)),
               "early": f"{early}/{len(firsts)}",
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
