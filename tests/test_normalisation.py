"""The two readings of D̂, Ê and ĵ (scdp.scoring.normalisation): per scene, and over the training data.

* the ``dataset`` reading of a few records equals a min-max over the given demonstrations computed
  here with numpy, D and E of each demonstration scored as a rollout is;
* it changes only what depends on the normalisation (D̂, Ê, ĵ, T, T_fa), never the path, success or
  legibility, and leaves the stored records as they were;
* ``scdp reproduce`` over a finished run re-scores under both readings and neither trains nor plans
  (slow: the tiny run).
"""

import json
import shutil

import numpy as np
import pytest

from scdp import metrics, scoring
from scdp.errors import ScdpError
from scdp.evaluation.normalised import under
from scdp.evaluation.records import TrajectoryRecord, record_value
from scdp.tasks import get_task


def record_of(task, path, goals, target, method="dp", index=0) -> TrajectoryRecord:
    m = scoring.score_path(task, path, goals, target)
    return TrajectoryRecord(task=task.name, scene_set="ambiguous", method=method, goals=np.asarray(goals).tolist(),
                            target=target, path=np.asarray(path).tolist(), success=bool(m["success"]),
                            bounds=scoring.reference_bounds(task, goals, target).to_dict(), j_hat=m["j_hat"],
                            metrics={k: m[k] for k in ("detachment", "efficiency", "d_hat", "e_hat", "transparency",
                                                       "legibility")},
                            beta=m["beta"], scene_index=index, protocol="random")


def some_records(task, dataset, n=4):
    """Records of paths that are not the demonstrations': each demo's path bent sideways, in its own scene."""
    out = []
    for i in range(n):
        ep = dataset.episode(i)
        path = task.episode_path(ep)
        bend = np.zeros_like(path)
        bend[:, 1] = 0.3 * np.sin(np.linspace(0, np.pi, len(path)))
        out.append(record_of(task, path + bend, ep["goals"], ep["target"], index=i))
    return out


@pytest.mark.parametrize("name", ["navigation", "block_reach"])
def test_the_dataset_reading_is_a_min_max_over_the_given_demonstrations(small_datasets, name):
    task, dataset = get_task(name), small_datasets[name]
    raw = []
    for i in range(dataset.num_episodes):
        ep = dataset.episode(i)
        raw.append((*scoring.raw_scores(task, task.episode_path(ep), ep["goals"], ep["target"]),
                    np.min(np.linalg.norm(np.delete(ep["goals"], ep["target"], 0) - ep["goals"][ep["target"]], axis=1))))
    lo, hi = np.min(raw, axis=0), np.max(raw, axis=0)
    records = some_records(task, dataset)
    stored = json.dumps([r.to_dict() for r in records])
    read = under(records, "dataset", {name: scoring.dataset_range(task, dataset)})
    assert json.dumps([r.to_dict() for r in records]) == stored  # the stored records are untouched
    for r, mine in zip(records, read):
        D, E = r.metrics["detachment"], r.metrics["efficiency"]
        d_hat, e_hat = (D - lo[0]) / (hi[0] - lo[0]), (E - lo[1]) / (hi[1] - lo[1])
        j = np.min(np.linalg.norm(np.delete(np.asarray(r.goals), r.target, 0) - np.asarray(r.goals)[r.target], axis=1))
        j_hat = min(max((j - lo[2]) / (hi[2] - lo[2]), 0.0), 1.0)
        w = 1 / (1 + np.exp(-2.5 * (j_hat - 0.5)))  # eq. 8, written out here
        assert mine.metrics["d_hat"] == pytest.approx(d_hat, abs=1e-12)
        assert mine.metrics["e_hat"] == pytest.approx(e_hat, abs=1e-12)
        assert mine.j_hat == pytest.approx(j_hat, abs=1e-12)
        assert mine.metrics["transparency"] == pytest.approx((1 - w) * d_hat + w * e_hat, abs=1e-9)
        assert mine.metrics["d_hat"] != pytest.approx(r.metrics["d_hat"], abs=1e-6)  # the scene's reading differs
        # what does not depend on the normalisation is left alone
        assert (mine.path, mine.success, mine.metrics["legibility"]) == (r.path, r.success, r.metrics["legibility"])
        assert record_value(mine, "transparency_fa") == metrics.failure_aware_transparency(mine.metrics["transparency"], r.success)


def test_the_scene_reading_is_the_stored_one_and_a_missing_range_is_named(small_datasets):
    task = get_task("navigation")
    records = some_records(task, small_datasets["navigation"], 2)
    assert [r.metrics for r in under(records, "scene")] == [r.metrics for r in records]
    with pytest.raises(ScdpError, match=r"normalisation: no training-data range for navigation"):
        under(records, "dataset", {})
    with pytest.raises(ScdpError, match=r"--normalisation: unknown normalisation 'paper'"):
        under(records, "paper")


def test_a_stored_range_whose_span_collapses_is_refused():
    rng = {"d_min": 1.0, "d_max": 1.0, "e_min": 0.0, "e_max": 1.0, "j_min": 0.1, "j_max": 2.0, "demos": 3}
    with pytest.raises(ScdpError, match=r"normalisation_ranges/navigation: d_min 1.0 and d_max 1.0 do not span a range"):
        scoring.DatasetRange.from_dict(rng, "normalisation_ranges/navigation")


@pytest.mark.slow
def test_reproduce_over_a_finished_run_rescores_both_readings_and_neither_trains_nor_plans(tiny_reproduction, tmp_path,
                                                                                         monkeypatch):
    from scdp.cli import main
    from scdp.data.dataset import DemoDataset

    out = tmp_path / "run"
    shutil.copytree(tiny_reproduction, out)
    for stale in [*out.glob("*/demos.normalisation.json"), out / "claims.json", out / "report.md"]:
        stale.unlink(missing_ok=True)

    def refuse(*args, **kwargs):
        raise AssertionError("a change of normalisation must not train or plan")

    monkeypatch.setattr("scdp.training.parts.train_part", refuse)
    monkeypatch.setattr("scdp.pipeline.evaluate.evaluate_methods", refuse)
    assert main(["reproduce", "--task", "all", "--preset", "tiny", "--out", str(out)]) == 0
    judged = json.loads((out / "claims.json").read_text())
    results = json.loads((out / "results.json").read_text())
    for name in ("navigation", "block_reach"):
        expected = scoring.dataset_range(get_task(name), DemoDataset.load(out / name / "demos.zarr")).to_dict()
        assert results["normalisation_ranges"][name] == pytest.approx(expected)
        assert json.loads((out / name / "demos.normalisation.json").read_text()) == pytest.approx(expected)
    assert judged["normalisation"] == "scene" and judged["dataset"]["claims"]
    assert {"scene", "dataset"} <= set(judged["verdicts"][0])
    scene_t = {(c["task"], c["claim"]): c["numbers"] for c in judged["claims"]}
    dataset_t = {(c["task"], c["claim"]): c["numbers"] for c in judged["dataset"]["claims"]}
    assert scene_t.keys() == dataset_t.keys() and scene_t != dataset_t
    assert "Table 1: adaptive transparency score T (mean ± std; D̂, Ê, ĵ over the training data)" in \
        (out / "table1_dataset.md").read_text()
    assert "## Every verdict under both normalisations" in (out / "report.md").read_text()
