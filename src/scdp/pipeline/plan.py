"""What ``scdp reproduce`` runs for one task (:func:`plan_stages`), what a run would redo
(:func:`pending`, nothing run), and ``--adopt`` (:func:`adopt_outputs`). The stages themselves:
:mod:`scdp.pipeline.stages`, :mod:`scdp.pipeline.evaluate`."""

from __future__ import annotations

from pathlib import Path

from scdp.config import Preset
from scdp.errors import ScdpError
from scdp.keys import LAYOUT_IDS, PER_LAYOUT, RANDOM, layout_name
from scdp.pipeline.evaluate import EvaluationStage
from scdp.pipeline.names import StageName
from scdp.pipeline.stages import AmbiguityStage, DemosStage, ModelSet, PartStage, Stage, protocols_of
from scdp.tasks import Task
from scdp.training.recipe import model_parts


def model_set_stages(ms: ModelSet) -> list[Stage]:
    """The stages that make one model set: its demos, then each part it trains."""
    protocol, layout = (RANDOM, None) if ms.scenes == RANDOM else (PER_LAYOUT, ms.scenes)
    return [DemosStage(ms, StageName("demos", protocol, layout))] + [
        PartStage(ms, p, StageName(p, protocol, layout)) for p in model_parts(ms.preset)]


def check_protocol_goals(protocol: str, preset: Preset) -> None:
    """Refuse the per-layout protocol with more than two goals per scene: the layouts hold two."""
    if PER_LAYOUT in protocols_of(protocol) and preset.data.goals != 2:
        raise ScdpError("--protocol", f"the per-layout protocol trains on the authors' two-goal layouts; "
                                      f"data.goals={preset.data.goals} needs --protocol random")


def plan_stages(task: Task, preset: Preset, folder: Path, protocol: str = RANDOM, layouts=LAYOUT_IDS, device="cpu") -> list[Stage]:
    """The stages ``reproduce`` runs for one task, in order."""
    device = str(device)
    check_protocol_goals(protocol, preset)
    main = ModelSet(task, preset, folder, folder / "checkpoints" / "encoder", device=device)
    stages = [AmbiguityStage(main), PartStage(main, "encoder")]
    if RANDOM in protocols_of(protocol):
        stages += model_set_stages(main) + [EvaluationStage(main, [main])]
    if PER_LAYOUT in protocols_of(protocol):
        sets = [ModelSet(task, preset.for_layout(k), folder / PER_LAYOUT / layout_name(k), main.encoder_dir, layout_name(k), device)
                for k in layouts]
        for ms in sets:
            stages += model_set_stages(ms)
        stages.append(EvaluationStage(main, sets, PER_LAYOUT))
    return stages


PHASES = 3  # what every model set needs; each model set; each evaluation (stage_phases)


def stage_phases(stages: list[Stage]) -> list[list[list[StageName]]]:
    """The stages' names as :data:`PHASES` phases of independent groups, each group a unit of work
    (:mod:`scdp.pipeline.executor`): the stages before the first demos (ambiguity, encoder: what every
    model set needs), one group per model set (its demos and parts), one group per evaluation. A
    phase starts when the one before it has finished; the groups within it may run at once."""
    first = next((i for i, s in enumerate(stages) if isinstance(s, DemosStage)), len(stages))
    sets: dict = {}
    for s in stages[first:]:
        if not isinstance(s, EvaluationStage):
            sets.setdefault(s.ms.folder, []).append(s.name)
    shared = [s.name for s in stages[:first]]
    return [[shared] if shared else [], list(sets.values()),
            [[s.name] for s in stages[first:] if isinstance(s, EvaluationStage)]]


def adopt_outputs(stages: list[Stage]) -> list[str]:
    """``--adopt``: before any stage runs, record today's inputs for every output whose record
    predates some of them and agrees on the rest (so nothing retrained in this run is taken for
    an input of an older output). Returns the adopted stages' names."""
    return [s.name for s in stages if s.adopt()]


def pending(stages: list[Stage], words: bool = False) -> list[tuple[str, list[str]]]:
    """(stage, the inputs that changed) for each stage a run would redo, in order; [] when the run
    is current. ``words``: each change as the log says it (a task's changed fields and probes named,
    :func:`scdp.content.explain`). Nothing is run or written."""
    return [(s.name, s.why() if words else c) for s in stages if (c := s.pending())]
