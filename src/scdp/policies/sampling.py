"""The denoising loop of a chunk, in one place: eager on any device, or replayed from one CUDA graph.

    x_K ~ N(0, I)  ──▶  for each step k of the sampler:  ε = U-Net(x, k, cond, film)  ──▶  x ← step(x, ε, noise_k)

Every random draw of a chunk (the start noise, then DDPM's noise of each step that adds some) is
made first, on the CPU generators, in the order the loop would make them (:func:`draw_noise`):
the same draws as drawing inside the loop, so plans do not depend on where or how the loop runs.

One loop serves every planner, sampler and device (:func:`denoise`): what differs is the network
call of a step (:func:`network_eps`, or a planner's own, :func:`guided_eps`) and the step itself
(:func:`ddpm_step`, or a diffusers scheduler's, :func:`scheduler_step`). Whether it runs eager or
replayed is :class:`scdp.policies.placement.Placement`'s to say. On a CUDA device, with the DDPM
sampler and the plain network call (no ``eps_fn``), the same loop is captured as one CUDA graph
(:class:`GraphCache`): once per (batch bucket, steps, warm start, film placement, first styled
step), and replayed for every chunk of that kind, so a chunk costs one graph launch instead of
about 330 kernel launches per network call. The batch is padded up to a power of two (the padded
rows are dropped), so a rollout whose scenes finish one by one reuses a few graphs. A style film
(FiLM γ, β; the style mixing of SCDP's films happens once per chunk before the loop) is a graph
input. The planners that call the network their own way per step (``eps_fn``: Legibility
Diffuser's goal guidance and SCDP's ``style_guidance``, whose per-chunk weights are not graph
inputs) and the DDIM and DPM-Solver samplers run the loop eager.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import torch

from scdp.models.film import Film
from scdp.models.unet1d import ConditionalUnet1D
from scdp.policies.ddpm_steps import DDPMSteps, StepTable, randn


def draw_noise(shape: tuple, generator, steps: DDPMSteps | None, run: list[int], device=None) -> tuple[torch.Tensor, list]:
    """The start noise (B, H, S) and, for DDPM, the noise of each step of ``run`` that adds some
    (None for the others), drawn on the CPU from ``generator`` (one, or one per scene) in the
    order the loop uses them, then moved to ``device`` (default: stay on the CPU) in one copy:
    all of a chunk's draws go up together, and each comes back as a view of that one tensor."""
    adds = [steps is not None and steps.adds_noise(i) for i in run]
    drawn = torch.stack([randn(shape, generator) for _ in range(1 + sum(adds))])  # (1 + N, B, H, S)
    drawn = drawn if device is None else drawn.to(device)
    x, rest = drawn[0], iter(drawn[1:])
    return x, [next(rest) if a else None for a in adds]


@dataclass
class Denoising:
    """One chunk's denoising on ``cond``'s device: the steps to run (``run``, indices into the
    sampler's timesteps), the network inputs, the pre-drawn noise, and the warm start (the rows
    of ``rows`` jump to ``renoised`` at step ``skip``)."""

    x: torch.Tensor  # (B, H, S) start noise
    cond: torch.Tensor  # (B, C) global condition
    film: Film | None
    film_from: int  # the film acts at timesteps >= this
    run: list[int]
    noises: list  # per step of run: (B, H, S) or None
    skip: int = 0
    renoised: torch.Tensor | None = None  # (B, H, S)
    rows: torch.Tensor | None = None  # (B, 1, 1) bool


Eps = Callable[[torch.Tensor, int], torch.Tensor]  # (x, i) -> ε at step i of the sampler's timesteps
Step = Callable[[int, torch.Tensor, torch.Tensor, "torch.Tensor | None"], torch.Tensor]  # (i, ε, x, noise) -> next x


def denoise(c: Denoising, eps: Eps, step: Step) -> torch.Tensor:
    """The denoising loop of one chunk, the only one: for each step i of ``c.run``, the warm scenes
    jump in at ``c.skip`` (their re-noised previous plan), then ``x <- step(i, eps(x, i), x, noise)``.
    x (B, H, S) after the last step. Every planner, sampler and device runs it: ``eps`` is the plain
    network call (:func:`network_eps`) or a planner's own (guidance), ``step`` DDPM's
    (:func:`ddpm_step`) or a diffusers scheduler's (:func:`scheduler_step`)."""
    x = c.x
    for j, i in enumerate(c.run):
        if c.skip and i == c.skip:  # the warm scenes start here, from their re-noised previous plan
            x = torch.where(c.rows, c.renoised, x)
        x = step(i, eps(x, i), x, c.noises[j])
    return x


def network_eps(unet: ConditionalUnet1D, c: Denoising, timesteps: torch.Tensor, ks: torch.Tensor | None = None) -> Eps:
    """The plain network call of ``c``: its condition, and its film at the timesteps >= ``c.film_from``
    (``ks``: the timesteps already on the device, as a graph needs them; default copied over now)."""
    ks = timesteps.to(c.x.device) if ks is None else ks
    B = c.x.shape[0]
    return lambda x, i: unet(x, ks[i].expand(B), c.cond, c.film if int(timesteps[i]) >= c.film_from else None)


def guided_eps(eps_fn, timesteps: torch.Tensor, batch: int, device) -> Eps:
    """A planner's own call per step, ``eps_fn(x, k, t)`` (``k`` the timestep as a (B,) tensor on the
    device, ``t`` as a Python int): LD's goal guidance, SCDP's style guidance."""
    return lambda x, i: eps_fn(x, timesteps[i].to(device).expand(batch), int(timesteps[i]))


def ddpm_step(steps: StepTable, table: list | None = None) -> Step:
    """DDPM's (or DDIM's) step with its constants computed once (``table``: on the device,
    :meth:`StepTable.on`, as a graph needs them; default the CPU's)."""
    return lambda i, eps, x, noise: steps.step(i, eps, x, noise=noise, table=table)


def scheduler_step(scheduler, generator) -> Step:
    """A sampler's step: its own (a :class:`StepTable`: DDPM, DDIM, constants computed once) or a
    diffusers scheduler's (DPM-Solver), which draws any noise it needs from ``generator``."""
    if isinstance(scheduler, StepTable):
        return ddpm_step(scheduler)
    return lambda i, eps, x, noise: scheduler.step(eps, scheduler.timesteps[i], x, generator=generator).prev_sample


def bucket(batch: int) -> int:
    """The batch a graph is captured for: the next power of two (the padded rows are dropped)."""
    return 1 << (batch - 1).bit_length()


def _pad(t: torch.Tensor | None, n: int, value: float = 0.0) -> torch.Tensor | None:
    if t is None or t.shape[0] == n:
        return t
    return torch.cat([t, t.new_full((n - t.shape[0], *t.shape[1:]), value)])


class GraphCache:
    """The CUDA graphs of one network's DDPM loop, each captured once and replayed for every chunk
    of its kind (its key: padded batch, steps run, warm-start step, film placement and steps)."""

    def __init__(self):
        self.graphs: dict = {}
        self.pool = None  # one memory pool for all of them: they never run at once

    def __len__(self) -> int:
        return len(self.graphs)

    def denoise(self, unet: ConditionalUnet1D, steps: DDPMSteps, c: Denoising) -> torch.Tensor:
        """:func:`denoise` of ``c`` replayed from a graph: (B, H, S)."""
        B, n = c.x.shape[0], bucket(c.x.shape[0])
        styled = tuple(int(steps.timesteps[i]) >= c.film_from for i in c.run) if c.film is not None else None
        key = (n, tuple(c.run), c.skip, None if c.film is None else (c.film.placement, c.film.gamma.shape[1]), styled,
               tuple(c.cond.shape[1:]), c.x.dtype)
        inputs = {"x": _pad(c.x, n), "cond": _pad(c.cond, n),
                  "noise": torch.stack([_pad(z, n) for z in c.noises if z is not None]) if any(
                      z is not None for z in c.noises) else c.x.new_zeros(1)}
        if c.film is not None:
            inputs["gamma"], inputs["beta"] = _pad(c.film.gamma, n, 1.0), _pad(c.film.beta, n)
        if c.skip:
            inputs["renoised"], inputs["rows"] = _pad(c.renoised, n), _pad(c.rows, n, False)
        if key not in self.graphs:
            self.graphs[key] = self._capture(unet, steps, c, inputs)
        graph, static, out, _ = self.graphs[key]
        for name, value in inputs.items():
            static[name].copy_(value)
        graph.replay()
        return out[:B].clone()

    def _capture(self, unet: ConditionalUnet1D, steps: DDPMSteps, c: Denoising, inputs: dict):
        """(graph, its static inputs, its output, every other device tensor it reads). The last is kept
        beside the graph for as long as the graph lives: the graph reads those tensors' memory at every
        replay, and a tensor dropped here would return its memory to the allocator for the next one."""
        static = {name: value.clone() for name, value in inputs.items()}
        table, ks = steps.on(c.x.device), steps.timesteps.to(c.x.device)  # copied before the capture
        noise_at = {j: k for k, j in enumerate(j for j, z in enumerate(c.noises) if z is not None)}

        def body():
            film = Film(static["gamma"], static["beta"], c.film.placement) if c.film is not None else None
            chunk = Denoising(static["x"], static["cond"], film, c.film_from, c.run,
                          [static["noise"][noise_at[j]] if j in noise_at else None for j in range(len(c.run))],
                          c.skip, static.get("renoised"), static.get("rows"))
            return denoise(chunk, network_eps(unet, chunk, steps.timesteps, ks), ddpm_step(steps, table))

        stream = torch.cuda.Stream()
        stream.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(stream):  # warm-up outside the graph: lazy initialisation, the allocator
            for _ in range(2):
                body()
        torch.cuda.current_stream().wait_stream(stream)
        if self.pool is None:
            self.pool = torch.cuda.graph_pool_handle()
        graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(graph, pool=self.pool, capture_error_mode="thread_local"):
            out = body()
        return graph, static, out, (table, ks)
