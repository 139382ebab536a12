"""What the project's observers read of a study's stimuli, and when a participant's pick stood.

Every observer of :data:`scdp.evaluation.observation.OBSERVERS` (the viewpoint one included), at its default
temperature, reads each stimulus's shown path (:func:`scdp.scoring.observed_path`). It is read two ways:

* by fraction of the motion (:func:`observer_correct` with ``grid``), as the project's observer metrics read it;
* by seconds of motion after a reaction delay (``seconds``): at second s the observer has seen the motion up to
  s - ``delay_s`` (nothing before the delay: no answer yet, so not correct). Every motion of a study plays at
  one speed, so a long motion gives a person more seconds to read it; by fraction, a fixed reaction time costs a
  short motion a larger share of it. Both are reported (:mod:`scdp.study.analysis`).

The analysis draws the observers beside the people; the screening compares a participant's early picks with
what the observers could read of the very same stimuli (:mod:`scdp.study.screening`).
"""

from __future__ import annotations

import numpy as np

from scdp import observers
from scdp.evaluation.observation import OBSERVERS, Belief
from scdp.scoring import observed_path
from scdp.study.record import Study
from scdp.tasks import get_task

REACTION_S = 0.5  # the observers' reaction delay, read in seconds: the simulated person's (ParticipantModel.delay_s)


def observer_correct(study: Study, stimuli: list[str], grid=None, *, seconds=None,
                     delay_s: float = REACTION_S) -> dict[str, np.ndarray]:
    """{observer: (len(stimuli), G) 0/1}: whether its arg-max is the stimulus's target at each fraction of
    ``grid``, or (``seconds`` given instead) at each second of motion after ``delay_s``."""
    if (grid is None) == (seconds is None):
        raise ValueError("read by fraction (grid) or by seconds, one of them")
    task = get_task(study.task)
    beliefs = {name: Belief(name) for name in OBSERVERS}
    size = len(grid) if grid is not None else len(seconds)
    out = {name: np.zeros((len(stimuli), size)) for name in OBSERVERS}
    for i, sid in enumerate(stimuli):
        stim = study.stimuli[sid]
        goals, target = np.asarray(stim.goals), stim.target
        path = observed_path(task, stim.path, goals, target)
        if grid is not None:
            fractions, seen = np.asarray(grid, dtype=np.float64), np.ones(size, dtype=bool)
        else:
            late = np.asarray(seconds, dtype=np.float64) - delay_s
            fractions, seen = np.clip(late / study.motion_s(sid), 0.0, 1.0), late >= -1e-9
        for name, belief in beliefs.items():
            post = belief.along_scene(task, path, goals, target, belief.default_beta())
            out[name][i] = np.asarray(observers.correct_at(post, target, fractions), dtype=np.float64) * seen
    return out


def pick_at(events: list[dict], when: float, key: str = "t") -> int | None:
    """The goal picked last at or before ``when`` (``key`` "t": a fraction of the motion; "s": seconds of it,
    the server's); None before the first pick."""
    latest = [e for e in events if e[key] <= when + 1e-9]
    return latest[-1]["goal"] if latest else None
