"""The stages of ``scdp reproduce``, and when each one may be skipped.

Each stage writes one output and records what it was made from, by content
(:mod:`scdp.pipeline.fingerprints`; file times play no part). A stage is skipped exactly when its
recorded inputs equal today's; so a killed run picks up where it stopped, a changed input redoes
what was made from it and nothing else, and :func:`pending` tells, without running anything, what
a run would redo.

Per task, in ``OUT/<task>/``:

1. ``ambiguity``  calibrate and compare the ambiguity definitions (``ambiguity.json/.md``)
                  and draw the ellipse for the first layout (``ellipse.png``)
2. ``encoder``    the scene autoencoder on random scenes (``checkpoints/encoder``), shared by
                  every model set of the task

The random-scene protocol (``--protocol random``, the default) then trains one model set:

3. ``demos``      generate the demonstrations (``demos.zarr``) and draw them (``demos.png``)
4. ``base``, ``style_legible``, ``style_efficient``, ``ld`` (and ``style_paper_legible``,
   ``style_paper_efficient`` when ``scdp_paper`` is evaluated): train each part into
   ``checkpoints/<part>``; a part interrupted mid-training resumes from its last checkpoint.
   A part is up to date when the record it wrote when it finished (:mod:`scdp.training.made_from`:
   recipe, task, demos, the weights it starts from) is today's
5. ``evaluate``   roll out DP, LD, SCDP and the dataset on the scene sets (``trajectories.json``;
                  :mod:`scdp.pipeline.evaluate`)

The authors' per-layout protocol (``--protocol per_layout``) trains one model set per layout
k, in ``per_layout/layout_k/``, from ``preset.layouts.demos`` demos of that layout only, runs
the same stages 3-4 there, and evaluates each set on its own layout
(``per_layout/trajectories.json``). ``--protocol both`` runs both.
"""

from __future__ import annotations

import sys
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from scdp.config import Preset
from scdp.content import RECORD, adoptable, changes, explain, under_an_older_task_key
from scdp.data.dataset import DemoDataset
from scdp.data.generate import generate_demos
from scdp.errors import ScdpError
from scdp.evaluation.calibration import ambiguity_report, report_markdown
from scdp.evaluation.figures import plot_demos, plot_ellipse, save_figure
from scdp.io import held, read_json_object, write_json, write_text
from scdp.keys import PER_LAYOUT, RANDOM
from scdp.pipeline.fingerprints import ambiguity_inputs, demos_hash, demos_inputs, older_record, part_inputs
from scdp.pipeline.names import StageName
from scdp.scoring import DatasetRange, dataset_range
from scdp.tasks import Task
from scdp.training import parts
from scdp.training.made_from import read_record, write_record

SKIPPED = "_skipped"  # key a stage sets in its outputs when its output was already valid
STAGES = ".stages"  # in a model set's folder: each stage's lock and the seconds it took when it last ran


@dataclass(frozen=True)
class ModelSet:
    """One set of models (base, two style predictors, LD base) and the demos they learn from.

    The random-scene protocol trains one per task in ``OUT/<task>``; the per-layout protocol
    one per layout in ``OUT/<task>/per_layout/layout_k``. All the sets of a task share its
    scene encoder. ``memo`` holds, for one run, the demos' fingerprint (hashed once per run; the demos
    stage sets it when it writes them).
    """

    task: Task
    preset: Preset  # for a per-layout set: ``preset.for_layout(k)``
    folder: Path
    encoder_dir: Path
    scenes: str = RANDOM  # the demos' scenes: "random" or "layout_k"
    device: str = "cpu"  # where its networks train and plan (scdp.devices); not part of what they are
    memo: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def checkpoints(self) -> Path:
        return self.folder / "checkpoints"

    @property
    def demos_path(self) -> Path:
        return self.folder / "demos.zarr"

    @property
    def label(self) -> str:
        return self.task.name if self.scenes == RANDOM else f"{self.task.name}/{self.scenes}"

    def part_inputs(self, part: str) -> dict:
        """What ``part`` of this set is made from today (:func:`scdp.pipeline.fingerprints.part_inputs`)."""
        return part_inputs(self.task, self.preset, part, demos=self.demos_fingerprint(), checkpoints=self.checkpoints,
                           encoder_dir=self.encoder_dir)

    def demos_fingerprint(self) -> str | None:
        """The demos' fingerprint, hashed once per run (the demos stage sets it when it writes them)."""
        if "demos" not in self.memo:
            self.memo["demos"] = demos_hash(self.demos_path)
        return self.memo["demos"]


def demos_regenerate(ms: ModelSet) -> bool:
    """Whether today's code makes ``ms``'s recorded demos again, bit for bit: the check behind adopting a
    record made under the older task key (:meth:`Stage.adopt`), never asked on a run's way otherwise."""
    recorded = ms.demos_fingerprint()
    return recorded is not None and _regenerates(ms.task, ms.preset.data, ms.scenes, recorded, ms.label)


@lru_cache(maxsize=16)
def _regenerates(task: Task, data, scenes: str, recorded: str, label: str) -> bool:
    """Generate the demos in memory (once per process for the same inputs) and compare fingerprints."""
    dataset, _ = generate_demos(task, data.num_demos, data.seed, scenes=scenes, n_goals=data.goals,
                                turning=data.turning, turn_from=data.turn_from)
    same = dataset.fingerprint() == recorded
    print(f"[{label}] demos {'regenerate' if same else 'no longer regenerate'} bit for bit with today's code")
    return same


class Stage(ABC):
    """One output of a run: ``inputs()`` (today's, by content), ``recorded()`` (what the output
    recorded; None: none), ``make(inputs)`` (write the output and its record), ``outputs()``. All
    four are abstract: a stage that forgot one cannot be built (an ``inputs`` left as ``...`` would
    return None, equal to a missing record's None, and read as up to date for ever)."""

    name: str
    ms: ModelSet

    @abstractmethod
    def inputs(self) -> dict: ...

    @abstractmethod
    def recorded(self) -> dict | None: ...

    @abstractmethod
    def make(self, inputs: dict) -> None: ...

    @abstractmethod
    def outputs(self) -> dict: ...

    def record(self, inputs: dict) -> None:
        """Record ``inputs`` as what the existing output was made from (``--adopt``)."""
        raise NotImplementedError

    def run(self) -> dict:
        """Skip when the recorded inputs are today's; else make the output, naming what changed.
        The stage's lock (:meth:`lock_path`) is held throughout, so two workers sharing the folder
        never make one output at once: the second waits, then finds it up to date."""
        with held(self.lock_path()):
            inputs, recorded = self.inputs(), self.recorded()
            if recorded == inputs:
                self.refresh()
                print(f"[{self.ms.label}] {self.name}: up to date, skipped")
                return {**self.outputs(), SKIPPED: True}
            if recorded is not None:
                print(f"[{self.ms.label}] {self.name}: changed since it was made: {', '.join(explain(recorded, inputs))}")
            self.make(inputs)
            return self.outputs()

    def lock_path(self) -> Path:
        """The file whose lock says a worker is making this stage's output (beside the model set's)."""
        return self.ms.folder / STAGES / f"{self.name.file_stem}.lock"

    def seconds_path(self) -> Path:
        """Where the seconds this stage took when it last ran are kept, written by whichever worker ran it."""
        return self.lock_path().with_suffix(".seconds")

    def refresh(self) -> None:  # noqa: B027 (an optional hook: most stages have nothing to write back)
        """Write back what an up-to-date output lacks but needs no work (a missing figure)."""

    def adopt(self) -> bool:
        """Record today's inputs for an output whose record predates some of them and agrees on
        the rest (:func:`~scdp.content.adoptable`), or differs only in being recorded under the older
        task key where today's code makes the recorded demos again bit for bit
        (:func:`~scdp.content.under_an_older_task_key`). Whether it was adopted."""
        inputs, recorded = self.inputs(), self.recorded()
        if adoptable(recorded, inputs) or (under_an_older_task_key(recorded, inputs) and self.demos_regenerate()):
            self.record(inputs)
            return True
        return False

    def demos_regenerate(self) -> bool:
        """Whether the demos this output was made from come out of today's code bit for bit."""
        return demos_regenerate(self.ms)

    def pending(self) -> list[str]:
        """What differs between the recorded and today's inputs ([]: a run would skip it)."""
        return changes(self.recorded(), self.inputs())

    def why(self) -> list[str]:
        """:meth:`pending` in words, as the log says it."""
        return explain(self.recorded(), self.inputs())


RANGE_FILE = "demos.normalisation.json"  # beside demos.zarr: the training data's range of D, E and j


def demos_range(folder: Path, *, keep: bool = True) -> DatasetRange | None:
    """The range of D, E and j over the demos in ``folder`` (:func:`scdp.scoring.dataset_range`), from
    :data:`RANGE_FILE` when it was taken from these demos, else computed (a second or two) and, with
    ``keep``, written there; None when the folder holds no demos. A command that only reads a run
    (``scdp verify``) passes ``keep=False`` and writes nothing into it."""
    if not (folder / "demos.zarr").exists():
        return None
    dataset = DemoDataset.load(folder / "demos.zarr")
    stored = read_json_object(folder / RANGE_FILE)
    if stored is not None and stored.get("fingerprint") == dataset.fingerprint():
        return DatasetRange.from_dict(stored, str(folder / RANGE_FILE))
    found = dataset_range(dataset.task_object(), dataset)
    if keep:
        write_json(folder / RANGE_FILE, found.to_dict())
    return found


class DemosStage(Stage):
    def __init__(self, ms: ModelSet, name: StageName = StageName("demos")):
        self.ms, self.name = ms, name

    def inputs(self) -> dict:
        return demos_inputs(self.ms.task, self.ms.preset, self.ms.scenes)

    @property
    def record_path(self) -> Path:
        """Beside the dataset, not in it: demos edited and saved again keep their record."""
        return self.ms.folder / "demos.inputs.json"

    def recorded(self) -> dict | None:
        record = read_json_object(self.record_path)
        if record is not None or self.ms.demos_fingerprint() is None:
            return record
        try:  # written before demos recorded their inputs: what the dataset says of its generator
            generator = DemoDataset.load(self.ms.demos_path).attrs.get("generator", {})
        except ScdpError:
            return None
        return older_record("demos", preset=self.ms.preset, found=generator)

    def record(self, inputs: dict) -> None:
        write_json(self.record_path, inputs)

    def make(self, inputs: dict) -> None:
        ms = self.ms
        dataset, report = generate_demos(ms.task, ms.preset.data.num_demos, ms.preset.data.seed, scenes=ms.scenes,
                                         n_goals=ms.preset.data.goals, turning=ms.preset.data.turning,
                                         turn_from=ms.preset.data.turn_from)
        dataset.save(ms.demos_path, force=True)
        self.record(inputs)
        ms.memo["demos"] = dataset.fingerprint()
        demos_range(ms.folder)
        save_figure(plot_demos(dataset, ms.task, 50), ms.folder / "demos.png")
        print(f"[{ms.label}] demos: {report['demos']} demos, {report['failures']} failures redrawn -> {ms.demos_path}")
        for warning in report["warnings"]:
            print(f"scdp: warning: [{ms.label}] demos: {warning}", file=sys.stderr)

    def refresh(self) -> None:
        demos_range(self.ms.folder)  # written by demos made before it existed
        if not (self.ms.folder / "demos.png").exists():
            save_figure(plot_demos(DemoDataset.load(self.ms.demos_path), self.ms.task, 50), self.ms.folder / "demos.png")

    def outputs(self) -> dict:
        return {"demos": str(self.ms.demos_path), "demo_figure": str(self.ms.folder / "demos.png"),
                "demos_range": str(self.ms.folder / RANGE_FILE)}


class AmbiguityStage(Stage):
    name = StageName("ambiguity")

    def __init__(self, ms: ModelSet):
        self.ms, self.path = ms, ms.folder / "ambiguity.json"

    def inputs(self) -> dict:
        return ambiguity_inputs(self.ms.task, self.ms.preset)

    def recorded(self) -> dict | None:
        report = read_json_object(self.path)
        if report is None:
            return None
        if "inputs" in report:
            return report["inputs"]
        return older_record("ambiguity", preset=self.ms.preset, found=report)  # written before reports recorded them

    def record(self, inputs: dict) -> None:
        write_json(self.path, {**read_json_object(self.path), "inputs": inputs})

    def make(self, inputs: dict) -> None:
        ms, n = self.ms, self.ms.preset.evaluation.ambiguity_scenes
        report = ambiguity_report(ms.task, n_random=n)
        write_json(self.path, {**report, "inputs": inputs})
        write_text(self.path.with_suffix(".md"), report_markdown(report))
        save_figure(plot_ellipse(ms.task, ms.task.layouts[0], 0), ms.folder / "ellipse.png")
        print(f"[{ms.label}] ambiguity: ellipse agrees with eq. 3 on {100 * report['random']['agreement']:.1f} % of {n} "
              f"scenes -> {self.path}")

    def refresh(self) -> None:
        if not (self.ms.folder / "ellipse.png").exists():
            save_figure(plot_ellipse(self.ms.task, self.ms.task.layouts[0], 0), self.ms.folder / "ellipse.png")

    def outputs(self) -> dict:
        return {"ambiguity_report": str(self.path), "ellipse_figure": str(self.ms.folder / "ellipse.png")}


def part_folder(ms: ModelSet, part: str) -> Path:
    return ms.encoder_dir if part == "encoder" else ms.checkpoints / part


def checkpoint_state(folder: Path, part: str, inputs: dict) -> str:
    """'done' (finished, and its record is ``inputs``), 'partial' (an interrupted run of the same
    inputs: resumable) or 'missing'."""
    meta = read_json_object(folder / "config.json") or {}
    if meta.get("part") != part:
        return "missing"
    if meta.get("complete") and read_record(folder) == inputs:
        return "done"
    job = (read_json_object(folder / "train_state.json") or {}).get("job")
    return "partial" if isinstance(job, dict) and all(job.get(k) == v for k, v in inputs.items()) else "missing"


class PartStage(Stage):
    def __init__(self, ms: ModelSet, part: str, name: StageName | None = None):
        self.ms, self.part, self.name = ms, part, name or StageName(part)
        self.folder = part_folder(ms, part)

    def inputs(self) -> dict:
        return self.ms.part_inputs(self.part)

    def recorded(self) -> dict | None:
        meta = read_json_object(self.folder / "config.json") or {}
        if not (meta.get("part") == self.part and meta.get("complete")):
            return None
        record = read_record(self.folder)
        if record is None:  # trained before parts recorded their inputs
            return older_record("part", preset=self.ms.preset, found=meta)
        return record

    def record(self, inputs: dict) -> None:
        write_record(self.folder, inputs)

    def make(self, inputs: dict) -> None:
        ms = self.ms
        resume = checkpoint_state(self.folder, self.part, inputs) == "partial"
        (self.folder / RECORD).unlink(missing_ok=True)
        dataset = DemoDataset.load(ms.demos_path) if self.part != "encoder" else None
        parts.train_part(ms.task, ms.preset, self.part, self.folder, dataset=dataset, base_dir=ms.checkpoints / "base",
                         encoder_dir=ms.encoder_dir, resume=resume, device=ms.device, record=inputs)
        print(f"[{ms.label}] {self.part}: trained -> {self.folder}")

    def outputs(self) -> dict:
        return {self.part: str(self.folder)}


def protocols_of(protocol: str) -> list[str]:
    """The protocols a ``--protocol`` value runs ("both" is random, then per_layout)."""
    return [RANDOM, PER_LAYOUT] if protocol == "both" else [protocol]
