"""How a simulated participant perceives a motion and decides, with or without a web page.

:class:`ParticipantModel` is the project's Bayesian observer (:func:`scdp.metrics.observer_posterior`, the
path-length observer) with the imperfections of a person: a reaction time, a misjudgement of the scene drawn
once per trial, looks at the motion every ``look_s`` seconds. :mod:`scdp.study.participant` drives it through
the real page in Chromium; :meth:`ParticipantModel.watch` applies the same rule to a path offline (no page,
no server), which is what sizing a study (:mod:`scdp.study.power`) and the design checks need by the thousand.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from scdp import metrics
from scdp.study.rules import flag


@dataclass(frozen=True)
class ParticipantModel:
    """How the simulated participant perceives and decides (motion seconds at playback rate 1)."""

    beta: float = metrics.DEFAULT_BETA  # the observer's rationality, as in the legibility metric
    noise: float = field(default=0.5, metadata=flag(  # drawn once per trial
        ("float_in", 0, 10), "the simulated person's noise: s.d. of the Gaussian offset on each goal's log belief"))
    delay_s: float = field(default=0.5, metadata=flag(  # acts on the motion as it was this long ago
        ("float_in", 0, 10), "the simulated person's reaction delay, in motion seconds"))
    look_s: float = 0.15  # looks at the motion this often
    confirm_s: float = 0.8  # seconds from the motion's end (and the last click) to pressing Confirm
    commit: float = 0.0  # clicks the most likely goal once its noisy belief reaches this (0: at once, as the
    #                      observer metrics' arg-max does)

    def belief(self, shown, goals) -> np.ndarray:
        """P(goal | the path shown so far), without knowing the target: (K,)."""
        shown, goals = np.asarray(shown, dtype=np.float64), np.asarray(goals, dtype=np.float64)
        if len(shown) < 2:
            return np.full(len(goals), 1.0 / len(goals))
        scale = max(float(np.mean(np.linalg.norm(goals - shown[0], axis=1))), 1e-9)
        return metrics.observer_posterior(shown, shown[0], goals, self.beta, scale)[-1]

    def confidence(self, p: np.ndarray) -> int:
        """1..5 from the final belief's largest probability (chance: 1, certain: 5)."""
        chance = 1.0 / len(p)
        return int(1 + round(4 * np.clip((float(np.max(p)) - chance) / (1 - chance), 0.0, 1.0)))

    def rate(self, path, goals) -> dict:
        """The end-of-study ratings of a motion drawn in full: legible from how early its belief settles on
        the goal the path ends at, predictable from how straight the path is (1..7)."""
        path, goals = np.asarray(path, dtype=np.float64), np.asarray(goals, dtype=np.float64)
        final = int(np.argmin(np.linalg.norm(goals - path[-1], axis=1)))
        wrong = [i for i in range(2, len(path) + 1) if int(np.argmax(self.belief(path[:i], goals))) != final]
        settled = (wrong[-1] / len(path)) if wrong else 0.0
        straight = np.linalg.norm(path[-1] - path[0]) / max(float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))), 1e-9)
        return {"legible": int(1 + round(6 * (1 - settled))), "predictable": int(1 + round(6 * min(1.0, straight)))}

    def noisy(self, p: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """``p`` (K,) with the trial's log-belief ``offsets`` (K,) added, renormalised."""
        logits = np.log(np.clip(p, 1e-12, 1.0)) + offsets
        e = np.exp(logits - logits.max())
        return e / e.sum()

    def sight(self, seen, goals, ended: bool) -> np.ndarray:
        """What a look at the path ``seen`` so far makes of it: the belief while the motion plays; once it has
        ended, the goal the robot stopped nearest, for certain (a person sees where it stopped)."""
        if not ended:
            return self.belief(seen, goals)
        d = np.linalg.norm(np.asarray(goals, dtype=np.float64) - np.asarray(seen, dtype=np.float64)[-1], axis=1)
        return np.eye(len(d))[int(np.argmin(d))]

    def decide(self, seen, goals, offsets: np.ndarray, picked: int | None, ended: bool = False) -> int | None:
        """The goal to click after a look that acts on the path ``seen`` so far (:meth:`sight`; ``ended``: the
        whole motion), the trial's log-belief ``offsets`` added: the most likely goal when it differs from
        ``picked`` and its belief reaches ``commit``; None when nothing is to be clicked."""
        p = self.noisy(self.sight(seen, goals, ended), offsets)
        k = int(np.argmax(p))
        return k if p[k] >= self.commit and k != picked else None

    def sights(self, path, goals, point_s: float) -> tuple[np.ndarray, np.ndarray]:
        """What the participant acts on over a motion of ``path`` (N, d) played at ``point_s`` s a point, without
        its noise: (look times (L,) in seconds, the belief (L, K) each look acts on). A look every ``look_s`` s of
        motion until ``delay_s`` after its end (a person reacts to the end too), each acting on the path up to the
        latest look at least ``delay_s`` old (:meth:`sight`; rows of NaN before the first such look: nothing to act
        on yet).
        Depends on the stimulus alone: computed once."""
        path, goals = np.asarray(path, dtype=np.float64), np.asarray(goals, dtype=np.float64)
        duration = (len(path) - 1) * point_s
        end = np.ceil(duration / self.look_s - 1e-9) * self.look_s  # the first look at or after the end
        looks = np.arange(1, int(np.ceil((end + self.delay_s) / self.look_s - 1e-9)) + 1) * self.look_s
        beliefs = np.full((len(looks), len(goals)), np.nan)
        for i, s in enumerate(looks):
            acted = looks[looks <= s - self.delay_s + 1e-9]
            if len(acted):
                beliefs[i] = self.sight(shown_path(path, acted[-1] / point_s), goals, acted[-1] >= duration - 1e-9)
        return np.minimum(looks, duration), beliefs  # a click after the end is stamped at the end, as the page does

    def picks(self, looks: np.ndarray, beliefs: np.ndarray, offsets: np.ndarray, final: np.ndarray) -> list[dict]:
        """The trial's clicks from its :meth:`sights` and log-belief ``offsets`` (K,): ``[{"t", "s", "goal"}]``, a
        click where the most likely goal changes and reaches ``commit`` (:meth:`decide`, at every look at once); the
        best guess from the ``final`` belief (K,) at the end when nothing was clicked. t is the fraction of the
        motion, s its seconds."""
        duration = float(looks[-1]) if len(looks) else 0.0  # sights() stamps the last looks at the end
        seen = ~np.isnan(beliefs[:, 0])
        logits = np.log(np.clip(beliefs[seen], 1e-12, 1.0)) + offsets
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        p /= p.sum(axis=1, keepdims=True)
        k = p.argmax(axis=1)
        sure = p[np.arange(len(k)), k] >= self.commit
        times, ks = looks[seen][sure], k[sure]
        change = np.r_[True, ks[1:] != ks[:-1]] if len(ks) else np.zeros(0, dtype=bool)
        events = [{"t": float(s / duration), "s": float(s), "goal": int(g)} for s, g in zip(times[change], ks[change])]
        return events or [{"t": 1.0, "s": duration, "goal": int(np.argmax(final))}]

    def watch(self, path, goals, point_s: float, rng: np.random.Generator) -> list[dict]:
        """The picks of one trial on a motion (:meth:`sights`, :meth:`picks`), its offsets drawn from ``rng``."""
        looks, beliefs = self.sights(path, goals, point_s)
        return self.picks(looks, beliefs, self.noise * rng.standard_normal(len(goals)), self.belief(path, goals))


def shown_path(path: np.ndarray, position: float) -> np.ndarray:
    """The path drawn up to ``position`` (in points, fractional): its whole points and the point between."""
    whole = int(np.floor(position))
    if whole >= len(path) - 1:
        return path
    part = position - whole
    return np.vstack([path[:whole + 1], (1 - part) * path[whole] + part * path[whole + 1]])
