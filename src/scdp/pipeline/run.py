"""``scdp reproduce``: every stage for one or both tasks (:mod:`scdp.pipeline.plan`), then the
report (:mod:`scdp.pipeline.report`); a summary of every output in ``OUT/summary.json``."""

from __future__ import annotations

import time
from pathlib import Path

from scdp.config import Preset
from scdp.data.scenes import check_layout
from scdp.errors import ScdpError
from scdp.io import check_output_path, write_json
from scdp.keys import LAYOUT_IDS, PER_LAYOUT, PROTOCOLS, RANDOM
from scdp.pipeline.plan import adopt_outputs, check_protocol_goals, pending, plan_stages
from scdp.pipeline.report import read_stage_times, write_report
from scdp.pipeline.stages import SKIPPED
from scdp.tasks import TASKS, get_task

# what marks a folder as a reproduction's own (one that is resumed): its bookkeeping, or a task's folder
REPRODUCTION_MARKERS = ("summary.json", "stage_times.json", *TASKS)


def check_reproduction_folder(out: Path, names=()) -> None:
    """Refuse an ``--out`` that is a file, or a non-empty folder that is not a reproduction's (none of
    :data:`REPRODUCTION_MARKERS` in it; hidden files aside): a mistyped ``--out`` pointing at a
    dataset or someone's work must not get a reproduction written into it. A new or empty folder,
    or a reproduction's (to resume or extend it), is accepted; ``names``: the tasks this run adds (a
    task of your own marks its folder too)."""
    if out.exists() and not out.is_dir():
        raise ScdpError("--out", f"{out} is a file, not a folder")
    if not out.is_dir():
        return
    entries = sorted(p.name for p in out.iterdir() if not p.name.startswith("."))
    if entries and not any(name in (*REPRODUCTION_MARKERS, *names) for name in entries):
        shown = ", ".join(entries[:3]) + (f" and {len(entries) - 3} more" if len(entries) > 3 else "")
        raise ScdpError("--out", f"{out} holds files that are not a reproduction's ({shown}); choose a new or empty folder")


def reproduce(task: str, preset: Preset, out, *, protocol: str = RANDOM, layouts=None, command: str = "",
              device="cpu", adopt: bool = False) -> dict:
    """Run every stage for ``task`` ("all" for both), then the report; write ``OUT/summary.json``.

    ``protocol`` is "random" (models trained on random scenes), "per_layout" (the authors' one
    model set per fixed layout) or "both"; ``layouts`` limits the per-layout protocol to some
    of the six layouts (default all). ``device`` is where the networks train and plan
    (:mod:`scdp.devices`); it is recorded in ``summary.json``. ``adopt`` takes outputs written
    before scdp recorded what they were made from as made from today's inputs, and records them
    (:func:`scdp.pipeline.plan.adopt_outputs`); without it such outputs are redone.
    """
    names = list(TASKS) if task == "all" else [get_task(task).name]
    if protocol not in PROTOCOLS:
        raise ScdpError("--protocol", f"unknown protocol {protocol!r} (choose from {', '.join(PROTOCOLS)})")
    layouts = sorted({check_layout(k, "--layouts") for k in (layouts or LAYOUT_IDS)})
    check_protocol_goals(protocol, preset)  # before anything is written
    out = Path(out)
    check_reproduction_folder(out, names)
    check_output_path(out / "summary.json", force=True)
    t0 = time.perf_counter()
    summary = {"command": command, "preset": preset.name, "overrides": list(preset.overrides or ()), "protocol": protocol,
               "device": str(device), "tasks": {}}
    times = read_stage_times(out)
    for name in names:
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        outputs = {}
        stages = plan_stages(get_task(name), preset, folder, protocol, layouts, device)
        if adopt:
            for adopted in adopt_outputs(stages):
                print(f"[{name}] adopted {adopted}: recorded as made from today's inputs")
        for stage in stages:
            print(f"[{name}] stage {stage.name} ...", flush=True)
            started = time.perf_counter()
            result = stage.run()
            if not result.pop(SKIPPED, False):  # a skipped stage keeps the time it took when it ran
                times[f"{name}/{stage.name}"] = round(time.perf_counter() - started, 2)
                write_json(out / "stage_times.json", times)
            if stage.ms.scenes == RANDOM:
                outputs.update({(f"{PER_LAYOUT}/{k}" if stage.name.startswith(f"{PER_LAYOUT}/") else k): v for k, v in result.items()})
            else:  # one line per per-layout model set
                outputs[f"{PER_LAYOUT}/{stage.ms.scenes}"] = str(stage.ms.folder)
        summary["tasks"][name] = outputs
    summary["report"] = write_report(out, names, preset, command, protocol)
    summary["wall_seconds"] = round(time.perf_counter() - t0, 1)
    write_json(out / "summary.json", summary)
    print(f"\ndone in {summary['wall_seconds']} s. Outputs:")
    for name, outputs in summary["tasks"].items():
        for key, value in outputs.items():
            print(f"  {name:12s} {key:24s} {value}")
    for key, value in summary["report"].items():
        print(f"  {'':12s} {key:24s} {value}")
    print(f"  {'':12s} {'summary':24s} {out / 'summary.json'}")
    return summary


def stale_stages(task: str, preset: Preset, out, *, protocol: str = RANDOM, layouts=None) -> list[tuple[str, str, list[str]]]:
    """(task, stage, the inputs that changed) for each stage ``reproduce`` would redo in ``out``, in
    order (``scdp reproduce --dry-run``); nothing is run or written. A stage after a stale one is
    listed by what differs today, which its upstream's redo may change further."""
    names = list(TASKS) if task == "all" else [get_task(task).name]
    if protocol not in PROTOCOLS:
        raise ScdpError("--protocol", f"unknown protocol {protocol!r} (choose from {', '.join(PROTOCOLS)})")
    layouts = sorted({check_layout(k, "--layouts") for k in (layouts or LAYOUT_IDS)})
    return [(name, stage, changed) for name in names
            for stage, changed in pending(plan_stages(get_task(name), preset, Path(out) / name, protocol, layouts), words=True)]
