"""The real-time gate, round 4 (issue 79): the few-step student (2 network calls per chunk) as the candidate.

Regenerates: `results/benchmarks/realtime_gate4_protocol.md`
(with --protocol-only: this protocol and its margins, written and committed before the run; the run itself
writes results/benchmarks/realtime_gate4.md).

    python benchmarks/realtime_gate4.py --protocol-only
    python benchmarks/realtime_gate4.py --protocol-commit C --out results/benchmarks/realtime_gate4

Protocol, committed before its one run and not edited after it:

* **Round 3's protocol unchanged** (``benchmarks/realtime_gate3.py``'s docstring, and through it round 2's),
  except for the candidate and the seeds: the same methods (dp, scdp, scdp_legible, scdp_efficient,
  scdp_blend), the same default (the checkpoints' DDPM-20, cold, torch), the same rules
  (:func:`scdp.evaluation.noninferiority.round_two` from results/cpu/claims.json; margins printed into
  the report), both readings, the SCDP − DP contrast, the null, the near-margin arm (films at half
  strength), the films-off arm and the arm just past the dataset reading's margins (films scaled by
  s_past, calibrated as in round 3), each of the last three must fail. The models are the committed cpu
  models at the protocol commit.
* **Candidate**: the few-step student (:mod:`scdp.training.distill`), DDIM at 2 steps, 2 network calls
  per chunk, cold: dp is planned by ``dp_student`` and each SCDP method by ``scdp_student`` with that
  method's style (``scdp_legible`` by ``scdp_student:legible``), the films from the same encoder and
  predictors. It is the student committed under results/cpu (one pass, points only: ``step_weight`` 0;
  the step term was tried and kept the styles worse, results/benchmarks/style_fidelity_step256.md). On
  validation seed 79 (results/benchmarks/style_fidelity.md) it kept 0.88 and 0.92 of the forced-style
  D̂ gap, and its observer read the legible style later on Block Reach (−0.06 [−0.12, −0.01]). It is
  **not servable yet**: it asks for a step beyond 1.5× the one-step reach in 8 and 4 of 40 benchmark
  rollouts (results/benchmarks/student_reach.md), which the safe service refuses. This round asks the
  question the issue asks, at the gate's N: does a 2-call student keep the styles? The films-off arm
  plans ``scdp_student:none``. Batched under torch, as in rounds 2 and 3.
* **Scenes**: validation stream, **seed 83** (no gate and no choice has used it), 800 + 800 per task.
  The past-margin arm's s_past is calibrated first on validation **seed 82**, 400 + 400 per task, dp
  and scdp only, before any scene of seed 83 is planned. If the null check fails at 800 the gate is
  uninformative and nothing changes.
* **Informative** when the null passes and the near-margin, films-off and past-dataset-margin arms
  all fail.
* **After.** The gate passes and is informative → the student keeps the styles at this N; it becomes
  the real-time planner of ``scdp plan``, ``serve``, ``deploy`` and the control loop only once it also
  asks for no step past the reach (0 of 40 on both tasks in student_reach.md), which this student does
  not: so not in this round. It fails → nothing changes; the note names each failed check and by how
  much, and nothing is tuned on seed 83.
"""

from __future__ import annotations

import sys

from realtime_gate import plan  # sibling benchmarks
from realtime_gate3 import ROUND_THREE, Round, run_round

from scdp.config import PlanningOptions

SEED, CALIBRATION_SEED = 83, 82
STUDENT_OPTIONS = PlanningOptions()  # the student's own sampler: DDIM-2, from its checkpoint


def plan_by_student(task, checkpoints, method, sets, seed, **how) -> list:
    return plan(task, checkpoints, method, STUDENT_OPTIONS, sets, seed=seed, student=True, **how)


ROUND_FOUR = Round(4, "the few-step student (DDIM-2, distilled) as the candidate", __doc__, SEED, CALIBRATION_SEED,
                   plan_by_student, {**ROUND_THREE.arms, "gate": "the few-step student: dp_student, scdp_student:<style>, DDIM-2"})


def main(argv=None) -> int:
    return run_round(ROUND_FOUR, argv)


if __name__ == "__main__":
    sys.exit(main())
