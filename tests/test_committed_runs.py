"""Every committed reproduction is what ``scdp reproduce`` makes today: each stage's recorded inputs
(a part's made-from record, the demos', the ambiguity report's, each evaluation's) equal what the
current code, presets and task definitions give (scdp.pipeline.plan.pending). No training, no
rollout: a change to a preset or a task that the committed results were not made with fails here,
naming the stage and the inputs that changed, instead of a user's fresh clone retraining."""

import json
import shlex
from pathlib import Path

import pytest

from scdp.cli import main
from scdp.pipeline.plan import pending, plan_stages
from scdp.presets import get_preset
from scdp.tasks import get_task

ROOT = Path(__file__).parents[1]


def committed_runs() -> list[Path]:
    """The committed reproductions (their ``summary.json`` names a ``scdp reproduce`` command), archives aside."""
    runs = []
    for summary in sorted((ROOT / "results").glob("*/summary.json")):
        command = json.loads(summary.read_text()).get("command", "")
        if command.startswith("scdp reproduce"):
            runs.append(summary.parent)
    return runs


def test_the_readme_s_committed_run_is_among_them():
    assert ROOT / "results" / "cpu" in committed_runs()
    readme = (ROOT / "README.md").read_text()
    command = json.loads((ROOT / "results" / "cpu" / "summary.json").read_text())["command"]
    assert shlex.split(command)[1:6] == ["reproduce", "--task", "all", "--preset", "cpu"]
    assert "scdp reproduce --task all --preset cpu" in readme


@pytest.mark.parametrize("run", committed_runs(), ids=lambda p: p.name)
def test_a_committed_run_is_current(run):
    summary = json.loads((run / "summary.json").read_text())
    preset = get_preset(summary["preset"], summary.get("overrides") or ())
    stale = []
    for name in summary["tasks"]:
        stages = plan_stages(get_task(name), preset, run / name, summary.get("protocol", "random"))
        stale += [f"{name}/{stage}: {', '.join(changed)}" for stage, changed in pending(stages)]
    assert not stale, f"{run.relative_to(ROOT)} is not what `{summary['command']}` makes today: " + "; ".join(stale)


def test_dry_run_names_what_a_run_would_redo_and_writes_nothing(capsys):
    """`reproduce --dry-run` reads the records only: on the committed run it finds nothing to redo; with
    the style predictors' epochs changed (what c7d85cb did to the cpu preset) it names them and the
    input that changed, and no file of the run changes."""
    before = {p: p.stat().st_mtime_ns for p in (ROOT / "results" / "cpu").rglob("*") if p.is_file()}
    assert main(["reproduce", "--task", "all", "--preset", "cpu", "--out", str(ROOT / "results" / "cpu"), "--dry-run"]) == 0
    assert "is up to date: nothing would be redone" in capsys.readouterr().out
    assert main(["reproduce", "--task", "navigation", "--preset", "cpu", "--set", "style.train.epochs=50",
                 "--out", str(ROOT / "results" / "cpu"), "--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "[navigation] style_legible: would be redone (recipe)" in lines
    assert "[navigation] style_efficient: would be redone (recipe)" in lines
    assert not any("base:" in line or "demos:" in line for line in lines)
    assert {p: p.stat().st_mtime_ns for p in (ROOT / "results" / "cpu").rglob("*") if p.is_file()} == before
