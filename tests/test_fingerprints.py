"""`scdp reproduce` decides what is up to date by content (scdp.pipeline.fingerprints), end to end on
a copy of the tiny run: a changed demonstration, preset field or upstream weight redoes exactly what
was made from it; copying the run, with or without its file times, or touching it, redoes nothing."""

import json
import os
import re
import shutil
from dataclasses import dataclass, fields, replace

import numpy as np
import pytest
from safetensors.numpy import load_file, save_file

from scdp.cli import main
from scdp.content import explain, file_sha256
from scdp.data.dataset import DemoDataset
from scdp.data.task_key import task_key
from scdp.pipeline.plan import adopt_outputs, pending, plan_stages
from scdp.presets import get_preset
from scdp.tasks import NavigationTask, get_task
from scdp.training.made_from import weights_hash

TASK = "navigation"


def _reproduce(out, capsys, *extra) -> set[str]:
    """Run reproduce on ``out`` (Navigation, tiny); the stages that ran rather than were skipped."""
    capsys.readouterr()
    assert main(["reproduce", "--task", TASK, "--preset", "tiny", "--out", str(out), *extra]) == 0
    text = capsys.readouterr().out
    ran = set(re.findall(r"\] (\w+): trained ->", text)) | {"evaluate" for _ in re.findall(r"evaluate: \d+ trajectories", text)}
    ran |= set(re.findall(r"\] (demos): \d+ demos", text))
    return ran


@pytest.fixture
def run_copy(tiny_reproduction, tmp_path):
    """A copy of the tiny run made as a checkout would: new file times, in an arbitrary order."""
    out = tmp_path / "run"
    shutil.copytree(tiny_reproduction, out, copy_function=shutil.copy)  # file times not kept
    rng = np.random.default_rng(7)
    for path in sorted(out.rglob("*")):
        when = float(rng.integers(10**8, 2 * 10**9))
        os.utime(path, (when, when))
    return out


def _weights(out) -> dict:
    return {p.parent.name: file_sha256(p) for p in (out / TASK / "checkpoints").glob("*/model.safetensors")}


def test_a_copied_and_touched_run_redoes_nothing(run_copy, capsys):
    before = _weights(run_copy)
    assert _reproduce(run_copy, capsys) == set()
    assert _weights(run_copy) == before


def test_one_changed_demonstration_byte_retrains_exactly_what_learns_from_the_demos(run_copy, capsys):
    path = run_copy / TASK / "demos.zarr"
    data = DemoDataset.load(path)
    data.action[0, 0] = np.nextafter(data.action[0, 0], np.float32(np.inf))  # one float, its last bit
    data.save(path, force=True)
    before = _weights(run_copy)
    assert _reproduce(run_copy, capsys) == {"base", "ld", "style_legible", "style_efficient", "style_paper_legible",
                                            "style_paper_efficient", "evaluate"}
    assert _weights(run_copy)["encoder"] == before["encoder"]  # (the tiny base may come out the same: it was redone)


def test_one_changed_section_field_retrains_exactly_its_parts(run_copy, capsys):
    assert _reproduce(run_copy, capsys, "--set", "paper_style.train.lr=0.002") == {"style_paper_legible", "style_paper_efficient",
                                                                                   "evaluate"}


def test_changed_upstream_weights_retrain_what_starts_from_them(run_copy, capsys):
    base = run_copy / TASK / "checkpoints" / "base"
    tensors = load_file(base / "model.safetensors")
    name = sorted(tensors)[0]
    tensors[name] = tensors[name] + np.float32(1e-3)
    save_file(tensors, base / "model.safetensors")
    meta = json.loads((base / "config.json").read_text())
    (base / "config.json").write_text(json.dumps({**meta, "weights_sha256": weights_hash(base)}))  # as a retrain leaves it
    assert _reproduce(run_copy, capsys) == {"ld", "style_legible", "style_efficient", "style_paper_legible",
                                            "style_paper_efficient", "evaluate"}


def test_a_part_trained_by_hand_is_taken_as_current(run_copy, capsys):
    """`scdp train` writes the same made-from record as reproduce: a predictor retrained by hand from
    the run's demos, base and encoder is current, and nothing after it is redone but what reads its
    (new) weights. Without the record (the trainer no longer writing it) reproduce retrains it."""
    folder = run_copy / TASK / "checkpoints" / "style_legible"
    shutil.rmtree(folder)
    assert main(["train", "style", "--style", "legible", "--task", TASK, "--preset", "tiny",
                 "--data", str(run_copy / TASK / "demos.zarr"), "--out", str(folder)]) == 0
    assert (folder / "inputs.json").is_file()
    assert _reproduce(run_copy, capsys) <= {"evaluate"}  # the same weights (seeded) or new ones: never retrained


def test_a_changed_task_field_redoes_everything_made_from_the_task(run_copy):
    """The task's definition is under the key: a changed field (a demonstration bend) redoes the
    ambiguity report, the demos and every part and evaluation; the same task again redoes nothing."""
    task, preset = get_task(TASK), get_preset("tiny")
    assert pending(plan_stages(task, preset, run_copy / TASK)) == []
    changed = replace(task, lateral_cap=task.lateral_cap / 2)
    stale = pending(plan_stages(changed, preset, run_copy / TASK))
    assert [name for name, _ in stale] == [s.name for s in plan_stages(task, preset, run_copy / TASK)]
    assert {tuple(c) for _, c in stale} == {("task",)}


@dataclass(frozen=True, eq=False)
class DocumentedNavigation(NavigationTask):
    """Navigation with a docstring of its own and a comment in a method: what it does is Navigation's."""

    def task_space(self, states):
        # a comment, and a local name of its own: the same behaviour
        points = super().task_space(states)
        return points


@dataclass(frozen=True, eq=False)
class SlowerNavigation(NavigationTask):
    """Navigation whose environment lags: each step covers 90 % of the way to the commanded state."""

    def make_env(self, **kwargs):
        env = super().make_env(**kwargs)
        apply = env.apply_action
        env.apply_action = lambda action: apply(env.state + 0.9 * (np.asarray(action) - env.state))
        return env


def _same_fields(cls):
    task = get_task(TASK)
    return cls(**{f.name: getattr(task, f.name) for f in fields(task)})


def test_a_docstring_or_comment_in_a_task_redoes_nothing(run_copy):
    """The task's key is what it does (scdp.data.task_key): a task class that differs from
    Navigation only in text keeps every stage of a Navigation run up to date."""
    assert task_key(_same_fields(DocumentedNavigation)) == task_key(get_task(TASK))
    assert pending(plan_stages(_same_fields(DocumentedNavigation), get_preset("tiny"), run_copy / TASK)) == []


def test_a_changed_environment_redoes_the_demos_and_everything_after_them(run_copy, capsys):
    """A lagging controller in the task's environment (no field changed) is under the key: every
    stage is stale, and the log names the probes that saw it."""
    task, preset = _same_fields(SlowerNavigation), get_preset("tiny")
    stale = pending(plan_stages(task, preset, run_copy / TASK))
    assert [name for name, _ in stale] == [s.name for s in plan_stages(task, preset, run_copy / TASK)]
    words = explain({"task": task_key(get_task(TASK))}, {"task": task_key(task)})
    assert words == ["task (probe demos; probe env_steps)"]


def test_the_log_names_a_changed_field_with_both_values():
    task = get_task(TASK)
    changed = replace(task, lateral_cap=0.125)
    assert explain({"task": task_key(task)}, {"task": task_key(changed)}) == [
        f"task (field lateral_cap {task.lateral_cap} -> 0.125; probe demos)"]


def _with_older_task_key(folder):
    """Rewrite every record under ``folder`` as scdp wrote them before tasks were keyed by behaviour."""
    older = "0" * 64
    for path in [*folder.glob("checkpoints/*/inputs.json"), folder / "demos.inputs.json"]:
        path.write_text(json.dumps({**json.loads(path.read_text()), "task": older}))
    for path in (folder / "ambiguity.json", folder / "trajectories.json"):
        report = json.loads(path.read_text())
        path.write_text(json.dumps({**report, "inputs": {**report["inputs"], "task": older}}))


def test_records_under_the_older_task_key_are_adopted_only_where_the_demos_regenerate(run_copy, capsys):
    folder, preset = run_copy / TASK, get_preset("tiny")
    _with_older_task_key(folder)
    assert {tuple(c) for _, c in pending(plan_stages(get_task(TASK), preset, folder))} == {("task",)}
    stages = plan_stages(get_task(TASK), preset, folder)
    assert adopt_outputs(stages) == [s.name for s in stages]  # today's code makes the recorded demos again
    assert pending(plan_stages(get_task(TASK), preset, folder)) == []
    _with_older_task_key(folder)
    data = DemoDataset.load(folder / "demos.zarr")
    data.state[0, 0] = np.nextafter(data.state[0, 0], np.float32(np.inf))  # demos today's code does not make
    data.save(folder / "demos.zarr", force=True)
    stages = plan_stages(get_task(TASK), preset, folder)
    assert adopt_outputs(stages) == []  # nothing adopted: every stage is redone


def test_a_clone_without_the_trajectory_files_restores_them_from_results_json(run_copy, capsys):
    """results.json is committed, trajectories.json is not (.gitignore): a fresh clone re-runs no rollout."""
    before = (run_copy / "results.json").read_bytes()
    (run_copy / TASK / "trajectories.json").unlink()
    capsys.readouterr()
    assert main(["reproduce", "--task", TASK, "--preset", "tiny", "--out", str(run_copy)]) == 0
    text = capsys.readouterr().out
    assert "restored from" in text and "trajectories ->" not in text
    restored = json.loads((run_copy / TASK / "trajectories.json").read_text())
    assert {r["task"] for r in restored["records"]} == {TASK} and len(restored["records"]) > 0
    results = json.loads((run_copy / "results.json").read_text())
    def mine(rows):  # (the shared tiny run may also hold another test's per-layout records: not reproduced here)
        return [r for r in rows if (r["task"], r["protocol"]) == (TASK, "random")]
    assert mine(results["trajectories"]) == mine(json.loads(before)["trajectories"])


def test_a_saved_pdf_carries_no_date(tmp_path, monkeypatch):
    """A rebuilt report gives the same bytes: figures are saved without a creation date (matplotlib
    would stamp one; SOURCE_DATE_EPOCH stands in for two different days)."""
    from matplotlib.figure import Figure

    from scdp.evaluation.figures import save_figure

    fig = Figure()
    fig.add_subplot().plot([0, 1], [1, 0])
    saved = []
    for day in (1_600_000_000, 1_700_000_000):
        monkeypatch.setenv("SOURCE_DATE_EPOCH", str(day))
        save_figure(fig, tmp_path / f"{day}.pdf")
        saved.append((tmp_path / f"{day}.pdf").read_bytes())
    assert saved[0] == saved[1]
