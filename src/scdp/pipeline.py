"""``scdp reproduce``: the paper's pipeline as resumable stages.

Each stage writes one output under ``OUT/<task>/`` and is skipped when that output already
exists and is valid, so a killed run picks up where it stopped. Stages so far:

1. ``demos``      generate the demonstrations (``demos.zarr``) and draw them (``demos.png``)
2. ``ambiguity``  calibrate and compare the ambiguity definitions (``ambiguity.json/.md``)
                  and draw the ellipse for the first fixed configuration (``ellipse.png``)

Training, evaluation and the paper's tables are added as they land.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from scdp.errors import ScdpError
from scdp.tasks import TASKS, get_task


@dataclass(frozen=True)
class Preset:
    name: str
    num_demos: int
    demo_seed: int = 0
    ambiguity_scenes: int = 10_000


PRESETS = {
    "cpu": Preset("cpu", num_demos=200),
    "paper": Preset("paper", num_demos=200),
    "tiny": Preset("tiny", num_demos=12, ambiguity_scenes=500),  # for tests
}


def get_preset(name: str) -> Preset:
    try:
        return PRESETS[name]
    except KeyError:
        raise ScdpError("--preset", f"unknown preset {name!r} (choose from {', '.join(PRESETS)})") from None


def _stage_demos(task, preset: Preset, folder: Path) -> dict:
    from scdp.data.dataset import DemoDataset
    from scdp.data.generate import generate_demos
    from scdp.plotting import plot_demos, save_figure

    path = folder / "demos.zarr"
    wanted = {"num_demos": preset.num_demos, "seed": preset.demo_seed}
    try:
        dataset = DemoDataset.load(path)
        gen = dataset.attrs.get("generator", {})
        valid = dataset.task == task.name and all(gen.get(k) == v for k, v in wanted.items())
    except ScdpError:
        valid = False
    if valid:
        print(f"[{task.name}] demos: {path} is up to date, skipped")
    else:
        dataset, report = generate_demos(task, preset.num_demos, preset.demo_seed)
        dataset.save(path, force=True)
        print(f"[{task.name}] demos: {report['demos']} demos, {report['failures']} failures redrawn -> {path}")
    figure = folder / "demos.png"
    if not valid or not figure.exists():
        save_figure(plot_demos(dataset, task, 50), figure)
    return {"demos": str(path), "demo_figure": str(figure)}


def _stage_ambiguity(task, preset: Preset, folder: Path) -> dict:
    from scdp.ambiguity import ambiguity_report
    from scdp.cli import report_markdown
    from scdp.io import write_json, write_text
    from scdp.plotting import plot_ellipse, save_figure

    path = folder / "ambiguity.json"
    try:
        valid = json.loads(path.read_text())["random"]["scenes"] == preset.ambiguity_scenes
    except (OSError, ValueError, KeyError, TypeError):
        valid = False
    if valid:
        print(f"[{task.name}] ambiguity: {path} is up to date, skipped")
    else:
        report = ambiguity_report(task, n_random=preset.ambiguity_scenes)
        write_json(path, report)
        write_text(path.with_suffix(".md"), report_markdown(report))
        print(f"[{task.name}] ambiguity: ellipse agrees with eq. 3 on "
              f"{100 * report['random']['agreement']:.1f} % of {preset.ambiguity_scenes} scenes -> {path}")
    figure = folder / "ellipse.png"
    if not figure.exists():
        save_figure(plot_ellipse(task, task.fixed_configs[0], 0), figure)
    return {"ambiguity_report": str(path), "ellipse_figure": str(figure)}


STAGES = [("demos", _stage_demos), ("ambiguity", _stage_ambiguity)]


def reproduce(task: str, preset: str, out, *, command: str = "") -> dict:
    """Run every stage for ``task`` ("all" for both) and write ``OUT/summary.json``."""
    from scdp.io import check_output_path, write_json

    preset_obj = get_preset(preset)
    names = list(TASKS) if task == "all" else [get_task(task).name]
    out = Path(out)
    check_output_path(out / "summary.json", force=True)
    t0 = time.perf_counter()
    summary = {"command": command, "preset": preset_obj.name, "tasks": {}}
    for name in names:
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        outputs = {}
        for stage, fn in STAGES:
            print(f"[{name}] stage {stage} ...", flush=True)
            outputs.update(fn(get_task(name), preset_obj, folder))
        summary["tasks"][name] = outputs
    summary["wall_seconds"] = round(time.perf_counter() - t0, 1)
    write_json(out / "summary.json", summary)
    print(f"\ndone in {summary['wall_seconds']} s. Outputs:")
    for name, outputs in summary["tasks"].items():
        for key, value in outputs.items():
            print(f"  {name:12s} {key:18s} {value}")
    print(f"  summary            {out / 'summary.json'}")
    return summary
