"""Adaptivity shares (scdp.evaluation.adaptivity), checked by hand on records built for the purpose.

Planners stand for the three behaviours the shares must tell apart: ``ld`` here is always legible
(it copies the forced legible style), ``dp`` always efficient, ``scdp`` legible exactly when needed,
``scdp_blend`` half-way in both scene sets.
"""

import pytest

from scdp.evaluation.adaptivity import adaptivity, adaptivity_markdown, path_length
from scdp.evaluation.records import TrajectoryRecord
from scdp.keys import AMBIGUOUS, CLEAR

LEGIBLE_D = (0.8, 0.7, 0.9, 0.75)  # forced legible D̂ in four ambiguous scenes
EFFICIENT_D = (0.2, 0.3, 0.1, 0.25)
LEGIBLE_LENGTH, EFFICIENT_LENGTH = (2.0, 2.2, 1.8, 2.1), (1.0, 1.1, 0.9, 1.2)  # clear scenes, metres
LEGIBLE_E, EFFICIENT_E = (0.3, 0.2, 0.35, 0.25), (0.9, 0.95, 0.85, 0.8)


def _record(method, scene_set, i, d_hat=0.0, e_hat=0.0, length=1.0):
    return TrajectoryRecord(task="navigation", scene_set=scene_set, method=method, goals=[[2, 0.2], [2, -0.2]], target=0,
                            path=[[0.0, 0.0], [length, 0.0]], success=True, bounds={}, j_hat=0.1,
                            metrics={"d_hat": d_hat, "e_hat": e_hat}, beta=4.0, scene_index=i)


def _records():
    out = []
    for i in range(4):
        ambiguous = {"scdp_legible": LEGIBLE_D[i], "scdp_efficient": EFFICIENT_D[i], "ld": LEGIBLE_D[i],
                     "dp": EFFICIENT_D[i], "scdp": LEGIBLE_D[i], "scdp_blend": (LEGIBLE_D[i] + EFFICIENT_D[i]) / 2}
        out += [_record(m, AMBIGUOUS, i, d_hat=d) for m, d in ambiguous.items()]
        legible = dict(e_hat=LEGIBLE_E[i], length=LEGIBLE_LENGTH[i])
        efficient = dict(e_hat=EFFICIENT_E[i], length=EFFICIENT_LENGTH[i])
        half = dict(e_hat=(LEGIBLE_E[i] + EFFICIENT_E[i]) / 2, length=(LEGIBLE_LENGTH[i] + EFFICIENT_LENGTH[i]) / 2)
        clear = {"scdp_legible": legible, "scdp_efficient": efficient, "ld": legible, "dp": efficient,
                 "scdp": efficient, "scdp_blend": half}
        out += [_record(m, CLEAR, i, **v) for m, v in clear.items()]
    return out


def _shares(rows):
    return {(r["planner"], r["scene_set"], r["measure"]): r for r in rows}


def test_always_legible_always_efficient_and_adaptive_score_as_they_should():
    shares = _shares(adaptivity(_records(), measured={}))
    expected = {"ld": (1.0, 0.0), "dp": (0.0, 1.0), "scdp": (1.0, 1.0), "scdp_blend": (0.5, 0.5),
                "scdp_legible": (1.0, 0.0), "scdp_efficient": (0.0, 1.0)}
    for planner, (ambiguous, clear) in expected.items():
        assert shares[(planner, AMBIGUOUS, "d_hat")]["share"] == pytest.approx(ambiguous)
        assert shares[(planner, CLEAR, "e_hat")]["share"] == pytest.approx(clear)
        assert shares[(planner, CLEAR, "path_length")]["share"] == pytest.approx(clear)
    # by hand: the half-way planner keeps sum(P - E) / sum(L - E) of D̂
    kept = sum((l_ + e) / 2 - e for l_, e in zip(LEGIBLE_D, EFFICIENT_D))
    assert shares[("scdp_blend", AMBIGUOUS, "d_hat")]["share"] == pytest.approx(kept / sum(l_ - e for l_, e in zip(LEGIBLE_D, EFFICIENT_D)))
    row = shares[("scdp", AMBIGUOUS, "d_hat")]
    assert row["n"] == 4 and row["styles_differ"] and row["lo"] == pytest.approx(1.0) and row["hi"] == pytest.approx(1.0)
    assert row["style_gap"] == pytest.approx((sum(LEGIBLE_D) - sum(EFFICIENT_D)) / 4)


def test_a_planner_between_the_styles_gets_an_interval_around_its_share():
    records = _records()
    for r in records:  # scdp keeps 3/4 of the gap in two scenes and 1/4 in the others: mean share 1/2, spread
        if r.method == "scdp" and r.scene_set == AMBIGUOUS:
            f = 0.75 if r.scene_index < 2 else 0.25
            r.metrics["d_hat"] = EFFICIENT_D[r.scene_index] + f * (LEGIBLE_D[r.scene_index] - EFFICIENT_D[r.scene_index])
    row = _shares(adaptivity(records, measured={}))[("scdp", AMBIGUOUS, "d_hat")]
    assert row["lo"] < row["share"] < row["hi"] and 0.25 - 1e-9 <= row["lo"] and row["hi"] <= 0.75 + 1e-9


def test_styles_that_do_not_differ_are_flagged():
    records = _records()
    for r in records:
        if r.method == "scdp_efficient" and r.scene_set == AMBIGUOUS:
            r.metrics["d_hat"] = LEGIBLE_D[r.scene_index] + (0.01 if r.scene_index % 2 else -0.01)
    rows = _shares(adaptivity(records, measured={}))
    assert not rows[("scdp", AMBIGUOUS, "d_hat")]["styles_differ"]
    assert rows[("scdp", CLEAR, "e_hat")]["styles_differ"]
    table = adaptivity_markdown([rows[("scdp", AMBIGUOUS, "d_hat")], rows[("scdp", CLEAR, "e_hat")]])
    row = next(line for line in table.splitlines() if line.startswith("| scdp |"))
    ambiguous_cell, clear_cell = row.strip("| ").split(" | ")[1:]
    assert ambiguous_cell.endswith("†") and not clear_cell.endswith("†")


def test_each_observer_is_read_at_half_the_motion():
    class Reads:  # a stand-in observer: right on a record whose D̂ is above one half
        def correct_at(self, percent):
            assert percent == 50
            return lambda r: float(r.metrics["d_hat"] > 0.5)

    rows = _shares(adaptivity(_records(), measured={"path_length": Reads()}))
    assert rows[("scdp", AMBIGUOUS, "path_length_correct_at_50")]["share"] == 1.0
    assert rows[("dp", AMBIGUOUS, "path_length_correct_at_50")]["share"] == 0.0
    assert ("scdp", CLEAR, "path_length_correct_at_50") not in rows


def test_path_length_is_the_stored_paths_length():
    assert path_length(_record("dp", CLEAR, 0, length=1.5)) == 1.5
    r = _record("dp", CLEAR, 0)
    r.path = [[0, 0], [3, 4], [3, 0]]
    assert path_length(r) == 9.0
