"""A simulated participant that takes a study through its HTTP API, without a browser.

The same person as :mod:`scdp.study.participant` (:class:`scdp.study.person.ParticipantModel`: a look every
``look_s`` s of motion, acting on the look ``delay_s`` old, a misjudgement drawn once per trial, the end seen
``delay_s`` after it), answering the same server on the same :class:`~scdp.study.participant.VirtualClock`:
every look asks ``/api/motion`` for what the server's clock allows, as the page's polls do, and a click is a
``/api/pick`` at that moment. The server's rules (the motion served no faster than it plays, picks stamped on
its clock, no Confirm before the end, the pick cap and rate) hold exactly as for the page; what it does not
exercise is the page itself (drawing, buttons, keyboard). About fifty times faster than the browser, for studies
of the size ``scdp study power`` recommends (``scdp study simulate --no-browser``).
"""

from __future__ import annotations

import zlib

import httpx
import numpy as np

from scdp.errors import ScdpError
from scdp.study import questions
from scdp.study.app import create_app
from scdp.study.design import API_STUDY_ID, SIMULATED_PREFIX
from scdp.study.participant import ServerThread, VirtualClock
from scdp.study.person import ParticipantModel, shown_path
from scdp.study.record import Study


def _post(client: httpx.Client, route: str, body: dict) -> dict:
    r = client.post(route, json=body)
    if r.status_code != 200:
        raise ScdpError("participant", f"{route} answered {r.status_code}: {r.text[:200]}")
    return r.json()


def take_trial(client: httpx.Client, state: dict, pid: str, model: ParticipantModel, rng: np.random.Generator,
               clock: VirtualClock) -> dict:
    """Watch one trial through the API and confirm it; the next state."""
    trial = state["trial"]
    index, goals, point_s = trial["index"], np.asarray(trial["goals"], dtype=np.float64), trial["point_s"]
    offsets = model.noise * rng.standard_normal(len(goals))
    m = _post(client, "/api/motion", {"pid": pid, "trial": index})
    elapsed, end, picked, looks = 0.0, None, state.get("picked"), []
    while end is None or elapsed < end + model.delay_s - 1e-9:
        clock.advance(model.look_s)
        elapsed += model.look_s
        m = _post(client, "/api/motion", {"pid": pid, "trial": index})
        path = np.asarray(m["path"], dtype=np.float64)
        done = bool(m["done"]) and m.get("ended", False)
        at = min(m["t"], (len(path) - 1) * point_s) if done else m["t"]  # the page's time: never past the end
        shown = shown_path(path, at / point_s)
        looks.append((elapsed, shown, done))
        seen = [(s, d) for when, s, d in looks if when <= elapsed - model.delay_s + 1e-9]
        if seen:
            k = model.decide(seen[-1][0], goals, offsets, picked, ended=seen[-1][1])
            if k is not None:
                _post(client, "/api/pick", {"pid": pid, "trial": index, "goal": k, "t": float(at)})
                picked = k
        if done and end is None:
            end = elapsed
    if picked is None:
        picked = int(np.argmax(model.belief(looks[-1][1], goals)))
        _post(client, "/api/pick", {"pid": pid, "trial": index, "goal": picked, "t": float(at)})
    if m.get("note"):  # an instruction, shown at the end: it is followed
        told = [k for k, c in enumerate(trial["colours"]) if f"the {c['name']} goal" in m["note"]]
        if told and told[0] != picked:
            clock.advance(model.look_s)
            _post(client, "/api/pick", {"pid": pid, "trial": index, "goal": told[0], "t": float(at)})
    clock.advance(model.confirm_s)
    confidence = model.confidence(model.noisy(model.belief(looks[-1][1], goals), offsets))
    return _post(client, "/api/response", {"pid": pid, "trial": index, "confidence": confidence})


def run_participant(client: httpx.Client, pid: str, model: ParticipantModel, seed: int, clock: VirtualClock) -> str:
    """One participant from consent to the completion code (returned)."""
    rng = np.random.default_rng(seed)
    state = _post(client, "/api/consent", {"pid": pid, "study_id": API_STUDY_ID})
    if state["screen"] == "instructions":
        state = _post(client, "/api/comprehension", {"pid": pid, "answers": list(questions.ANSWERS)})
    while state["screen"] == "trial":
        state = take_trial(client, state, pid, model, rng, clock)
    if state["screen"] == "ratings":
        given = [{"item": item["item"], **model.rate(item["motion"]["path"], item["trial"]["goals"])}
                 for item in state["items"]]
        state = _post(client, "/api/ratings", {"pid": pid, "ratings": given})
    if state["screen"] != "done":
        raise ScdpError("participant", f"{pid} ended on the {state['screen']} screen")
    return state["code"]


def simulate(study: Study, folder, store, count: int, *, model: ParticipantModel = ParticipantModel(),
             seed: int = 0, progress=None) -> list[str]:
    """``count`` simulated participants (IDs ``SIM-001``...) through the study's API on a virtual clock; their codes.
    Their noise streams are those of the browser's participants of the same ``seed``."""
    clock, codes = VirtualClock(), []
    with ServerThread(create_app(study, folder, store, clock=clock)) as url:
        for i in range(count):
            own_seed = int(np.random.SeedSequence([zlib.crc32(b"simulated-participant"), seed, i]).generate_state(1)[0])
            with httpx.Client(base_url=url, timeout=30.0) as client:  # one cookie jar a participant, as one browser
                codes.append(run_participant(client, f"{SIMULATED_PREFIX}{i + 1:03d}", model, own_seed, clock))
            if progress:
                progress(i + 1)
    return codes
