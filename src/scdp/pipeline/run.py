"""``scdp reproduce``: every stage for one or both tasks (:mod:`scdp.pipeline.plan`), then the
report (:mod:`scdp.pipeline.report`); a summary of every output in ``OUT/summary.json``."""

from __future__ import annotations

import time
from pathlib import Path

from scdp.config import Preset
from scdp.data.scenes import check_layout
from scdp.errors import ScdpError
from scdp.io import check_output_path, write_json, write_text
from scdp.keys import LAYOUT_IDS, PER_LAYOUT, PROTOCOLS, RANDOM
from scdp.pipeline.executor import LocalExecutor, Unit
from scdp.pipeline.plan import PHASES, adopt_outputs, check_protocol_goals, pending, plan_stages, stage_phases
from scdp.pipeline.report import read_stage_times, write_report
from scdp.pipeline.stages import SKIPPED
from scdp.tasks import TASKS, get_task, task_reference

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


def run_stages(task: str, preset: Preset, folder: str, protocol: str, layouts: list, device: str, names: list[str],
               *, report=lambda done: None) -> dict:
    """A unit of work (:class:`scdp.pipeline.executor.Unit`): the stages ``names`` of ``task``'s plan in
    ``folder``, in order. Returns their outputs (the summary's lines). Each stage that runs keeps its
    seconds beside its lock (:meth:`~scdp.pipeline.stages.Stage.seconds_path`); a skipped one keeps
    the time it took when it ran."""
    stages = {s.name: s for s in plan_stages(get_task(task), preset, Path(folder), protocol, layouts, device)}
    label = get_task(task).name
    outputs = {}
    for done, name in enumerate(names, 1):
        stage = stages[name]
        print(f"[{label}] stage {name} ...", flush=True)
        started = time.perf_counter()
        result = stage.run()
        if not result.pop(SKIPPED, False):  # kept at once: a unit killed later loses none of it
            write_text(stage.seconds_path(), f"{time.perf_counter() - started:.2f}\n")
        if stage.ms.scenes == RANDOM:
            outputs.update({(f"{PER_LAYOUT}/{k}" if stage.name.protocol == PER_LAYOUT else k): v for k, v in result.items()})
        else:  # one line per per-layout model set
            outputs[f"{PER_LAYOUT}/{stage.ms.scenes}"] = str(stage.ms.folder)
        report(done)
    return outputs


def _check_arguments(task: str, protocol: str, layouts) -> tuple[list[str], list[int]]:
    names = list(TASKS) if task == "all" else [get_task(task).name]
    if protocol not in PROTOCOLS:
        raise ScdpError("--protocol", f"unknown protocol {protocol!r} (choose from {', '.join(PROTOCOLS)})")
    return names, sorted({check_layout(k, "--layouts") for k in (layouts or LAYOUT_IDS)})


def reproduce(task: str, preset: Preset, out, *, protocol: str = RANDOM, layouts=None, command: str = "",
              device="cpu", adopt: bool = False, seeds=None, executor=None) -> dict:
    """Run every stage for ``task`` ("all" for both), then the report; write ``OUT/summary.json``.

    ``protocol`` is "random" (models trained on random scenes), "per_layout" (the authors' one
    model set per fixed layout) or "both"; ``layouts`` limits the per-layout protocol to some
    of the six layouts (default all). ``device`` is where the networks train and plan
    (:mod:`scdp.devices`); it is recorded in ``summary.json``. ``adopt`` takes outputs written
    before scdp recorded what they were made from as made from today's inputs, and records them
    (:func:`scdp.pipeline.plan.adopt_outputs`); without it such outputs are redone.

    ``seeds``: one whole reproduction per training seed, in ``OUT/seed_K`` (the preset's seed when
    None: the reproduction is ``OUT`` itself). ``executor`` (:mod:`scdp.pipeline.executor`; local
    when None) runs the independent units: every seed and task's shared stages, then each model set,
    then each evaluation; the reports are written here. Returns the summary (the seeds' summaries
    under ``seeds`` with several).
    """
    names, layouts = _check_arguments(task, protocol, layouts)
    check_protocol_goals(protocol, preset)  # before anything is written
    executor = executor or LocalExecutor()
    out = Path(out)
    runs = {out: preset} if seeds is None else {out / f"seed_{k}": preset.with_training_seed(k) for k in seeds}
    if seeds is not None and out.is_dir() and any(not p.name.startswith((".", "seed_")) for p in out.iterdir()):
        raise ScdpError("--out", f"{out} holds files that are not seed_K folders; choose a new or empty folder for --seeds")
    for folder in runs:
        check_reproduction_folder(folder, names)
        check_output_path(folder / "summary.json", force=True)
    t0 = time.perf_counter()
    plans = {}  # (folder, task) -> its stages
    for folder, p in runs.items():
        for name in names:
            (folder / name).mkdir(parents=True, exist_ok=True)
            plans[folder, name] = plan_stages(get_task(name), p, folder / name, protocol, layouts, str(device))
            if adopt:
                for adopted in adopt_outputs(plans[folder, name]):
                    print(f"[{name}] adopted {adopted}: recorded as made from today's inputs")
    done = {key: {} for key in plans}  # (folder, task) -> the summary's lines
    phases = {key: stage_phases(stages) for key, stages in plans.items()}
    for phase in range(PHASES):
        units, keys = [], []
        for (folder, name), groups in phases.items():
            for group in groups[phase]:
                seed = f"{folder.name} " if seeds is not None else ""
                what = ("shared", group[0].model_set, group[0])[phase]  # e.g. per_layout/layout_2
                units.append(Unit(f"{seed}{name} {what}", run_stages,
                                  (task_reference(name), runs[folder], str(folder / name), protocol, layouts, str(device), group),
                                  steps=len(group), gpus=1.0 if str(device).startswith("cuda") else 0.0))
                keys.append((folder, name))
        for key, outputs in zip(keys, executor.run(units)):
            done[key].update(outputs)
    ran_on = executor.describe()
    summaries = {}
    for folder, p in runs.items():
        times = read_stage_times(folder)  # a stage run before its seconds were kept beside it keeps its entry
        for name in names:
            times.update({s.name.timed(name): float(s.seconds_path().read_text()) for s in plans[folder, name]
                          if s.seconds_path().is_file()})
        write_json(folder / "stage_times.json", times)
        summary = {"command": command, "preset": p.name, "overrides": list(p.overrides or ()), "protocol": protocol,
                   "device": str(device), "executor": ran_on,
                   "tasks": {name: done[folder, name] for name in names}}
        summary["report"] = write_report(folder, names, p, command, protocol, executor=ran_on)
        summary["wall_seconds"] = round(time.perf_counter() - t0, 1)
        write_json(folder / "summary.json", summary)
        summaries[str(folder)] = summary
    print(f"\ndone in {round(time.perf_counter() - t0, 1)} s ({ran_on}). Outputs:")
    for summary in summaries.values():
        for name, outputs in summary["tasks"].items():
            for key, value in outputs.items():
                print(f"  {name:12s} {key:24s} {value}")
        for key, value in summary["report"].items():
            print(f"  {'':12s} {key:24s} {value}")
    for folder in runs:
        print(f"  {'':12s} {'summary':24s} {folder / 'summary.json'}")
    return next(iter(summaries.values())) if seeds is None else {"seeds": summaries, "executor": ran_on}


def stale_stages(task: str, preset: Preset, out, *, protocol: str = RANDOM, layouts=None) -> list[tuple[str, str, list[str]]]:
    """(task, stage, the inputs that changed) for each stage ``reproduce`` would redo in ``out``, in
    order (``scdp reproduce --dry-run``); nothing is run or written. A stage after a stale one is
    listed by what differs today, which its upstream's redo may change further."""
    names, layouts = _check_arguments(task, protocol, layouts)
    return [(name, stage, changed) for name in names
            for stage, changed in pending(plan_stages(get_task(name), preset, Path(out) / name, protocol, layouts), words=True)]
