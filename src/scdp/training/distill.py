"""The few-step student: the base's deterministic sampler distilled into one of a few steps that
takes the same style films (methods ``dp_student`` and ``scdp_student``).

The teacher is the frozen base planned with DDIM (η = 0) at ``student.teacher_steps`` steps: a
deterministic map from a chunk's start noise z to its clean chunk, so that a student can learn it
(a stochastic sampler has no single answer for one z, and regressing on it would average a path's
two sides into the middle). The student is a copy of the base, the same network with the same FiLM
slots, fine-tuned so that DDIM at ``student.steps`` steps from the same z, condition and film
reaches the teacher's chunk, point by point and step by step (MSE in the scaled action space)::

    z ~ N(0, I) (B, H, S)    film: none, legible or efficient per window (the style predictors, frozen)
    x_teacher = DDIM_N(base,    z, cond, film)      no gradient
    x_student = DDIM_n(student, z, cond, film)      gradient through its n calls
    loss      = mean (x_student - x_teacher)² + w · mean (Δx_student - Δx_teacher)²     Δ: along the horizon

The second term (``student.step_weight`` w, 0 by default: off) holds each step of the chunk, not only
each point. A student matched on points alone asks for up to 2.6× the robot's one-step reach, which
the safe service refuses (results/benchmarks/student_reach.md). With w = H², an offset that grows
evenly along the chunk costs about 3.3 times its point term in the step term (6H²/((H - 1)(2H - 1))),
and a single point out of line about 550 times (2H³/(H - 1), for H = 16). Tried at w = 256 on the cpu
models, it did not stop the jumps (3 and 10 of 40 rollouts past the reach, against 8 and 4 without it;
7 of its 11 Block Reach jumps at a chunk's first action, where the student without it had none), and
its paths moved further from the full sampler's (results/benchmarks/style_fidelity_step256.md,
student_reach_step256.md).

The films come from the same encoder and predictors SCDP plans with, and act at the same steps
(the predictors' noise window), so the style predictors keep modulating a network that reads
their films as the base did: nothing about the style is retrained. A window is distilled without
a film (what ``dp_student`` plans with) with probability ``1 - student.styled``, else with the
legible or the efficient film, half each.

Shapes: B batch, H horizon, S state dim.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from scdp.data.windows import TrainBatch
from scdp.models.film import Film
from scdp.policies.diffusion import DiffusionPolicy
from scdp.policies.sampling import Denoising, denoise, network_eps, scheduler_step
from scdp.policies.scdp import StyleConditionedPolicy

TEACHER_SAMPLER = "ddim"  # deterministic: one clean chunk per start noise
NONE, LEGIBLE, EFFICIENT = 0, 1, 2  # the film a window is distilled with


def deterministic_chunk(policy: DiffusionPolicy, z: torch.Tensor, cond: torch.Tensor, film: Film | None,
                        film_from: int) -> torch.Tensor:
    """The clean chunk (B, H, S), scaled, that ``policy``'s DDIM sampler (η = 0: it draws nothing)
    reaches from the start noise ``z`` (B, H, S); differentiable where the caller enables gradients."""
    sampler = policy.sampler()
    run = list(range(len(sampler.timesteps)))
    chunk = Denoising(z, cond, film, film_from, run, [None] * len(run))
    return denoise(chunk, network_eps(policy.unet, chunk, sampler.timesteps), scheduler_step(sampler, None))


def chunk_loss(chunk: torch.Tensor, target: torch.Tensor, step_weight: float) -> torch.Tensor:
    """The student's loss of a (B, H, S) chunk against the teacher's: its points' MSE plus
    ``step_weight`` times its steps' (the differences along the horizon)."""
    points = F.mse_loss(chunk, target)
    return points + step_weight * F.mse_loss(chunk.diff(dim=1), target.diff(dim=1)) if step_weight else points


def draw_films(n: int, styled: float, generator: torch.Generator) -> torch.Tensor:
    """(n,) codes: :data:`NONE` with probability ``1 - styled``, else :data:`LEGIBLE` or :data:`EFFICIENT`, half each."""
    u = torch.rand(n, generator=generator)
    return torch.where(u >= styled, NONE, torch.where(u < styled / 2, LEGIBLE, EFFICIENT))


class Distillation:
    """The student's loss against ``teacher`` (SCDP on the frozen base, planned with DDIM at its
    teacher steps; it supplies the films and the base), for the training loop."""

    def __init__(self, teacher: StyleConditionedPolicy, student: DiffusionPolicy, styled: float, step_weight: float):
        if teacher.base.config.sampler != TEACHER_SAMPLER or student.config.sampler != TEACHER_SAMPLER:
            raise ValueError("the teacher and the student plan with DDIM (deterministic)")
        self.teacher, self.student, self.styled, self.step_weight = teacher, student, styled, step_weight

    def films(self, batch: TrainBatch, codes: torch.Tensor) -> Film:
        """Each window's film (B, W): the predictor of its code's style at its current point, identity for none."""
        legible = (codes == LEGIBLE).double().numpy()
        film = self.teacher.film(batch.goals, batch.target, legible, batch.obs_position[:, -1])
        plain = (codes == NONE).to(film.gamma.device)[:, None]
        return Film(torch.where(plain, 1.0, film.gamma), torch.where(plain, 0.0, film.beta), film.placement)

    def loss(self, batch: TrainBatch, generator: torch.Generator) -> torch.Tensor:
        base = self.teacher.base
        device = batch.obs_state.device
        B, H, S = batch.action.shape
        codes = draw_films(B, self.styled, generator)
        z = torch.randn((B, H, S), generator=generator).to(device)  # drawn on the CPU: the same on any device
        with torch.no_grad():
            cond = base.observe(batch.obs_state, batch.goal, batch.obs_position)
            film = self.films(batch, codes)
            target = deterministic_chunk(base, z, cond, film, self.teacher.film_from)
        return chunk_loss(deterministic_chunk(self.student, z, cond, film, self.teacher.film_from), target, self.step_weight)

    @torch.no_grad()
    def gap(self, batch: TrainBatch, generator: torch.Generator) -> float:
        """The loss without gradients: how far the student's chunks are from the teacher's (a held-out check;
        with a step term, comparable only between distillations of one ``step_weight``)."""
        return float(self.loss(batch, generator))

