"""Goal-conditioned, state-based Diffusion Policy (DDPM, ε-prediction, receding horizon).

Observation: the last ``n_obs_steps`` states and the target g*, i.e. ``[s, g*]`` per step;
distractors are not an input. The network predicts ``horizon`` actions (next states)
starting at the first observed step; actions ``n_obs_steps - 1 ...`` are executed,
``n_action_steps`` of them per call. Everything inside works on [-1, 1]-scaled values.

With ``relative_actions`` (the default) the chunk is predicted as displacements from the
current state ``s_t`` and turned back into absolute next states on the way out. The scaled
range then spans one chunk's motion instead of the whole workspace, which makes the
centimetre-scale structure of a path (a TurtleBot turning on the spot) learnable by a small
network; the environments still receive absolute next states.

A **warm start** (``warm_skip`` k > 0) begins a chunk from the previous chunk's plan instead of
pure noise: the plan is shifted by the actions taken since, re-noised to the k-th step of the
sampler's schedule, and denoised from there, so a chunk costs ``steps - k`` network calls. A scene
starts cold when it has no previous plan, when its style weight moved by more than
:data:`STYLE_TOLERANCE` (a style flip always), or when the robot is not where the plan said
(:data:`JUMP_TOLERANCE`, scaled units). With k = 0 sampling is exactly the cold one.

Shapes: B batch, O = n_obs_steps, H = horizon, S = state dim, G = goal dim.
"""

from __future__ import annotations

import importlib

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from scdp.config import DiffusionConfig
from scdp.data.normalizer import Normalizer
from scdp.data.windows import TrainBatch
from scdp.devices import upload
from scdp.errors import ScdpError
from scdp.models.unet1d import ConditionalUnet1D
from scdp.policies.base import Chunk, Observation, WarmStart
from scdp.policies.ddim_steps import DDIMSteps
from scdp.policies.ddpm_steps import DDPMSteps, StepTable
from scdp.policies.noise_schedule import add_noise, alphas_cumprod
from scdp.policies.placement import Placement
from scdp.policies.sampling import Denoising, GraphCache, denoise, draw_noise, guided_eps, network_eps, scheduler_step

STYLE_TOLERANCE = 0.1  # a change of a scene's legible weight beyond this starts it cold
JUMP_TOLERANCE = 0.05  # scaled state units (of [-1, 1]): the robot this far from the plan starts cold


# DDPM and DDIM are scdp's own steps (constants computed once, bit for bit diffusers'). DPM-Solver is diffusers'
# scheduler, in a module loaded by name on its first use (the one deferred import of a policy: diffusers'
# import pulls in torch._dynamo, and the others need none of it)
OWN_STEPS = {"ddpm": DDPMSteps, "ddim": DDIMSteps}
DIFFUSERS_SAMPLERS = "scdp.policies.schedulers"


class DiffusionPolicy(nn.Module):
    """The base policy (method ``dp``), and the network SCDP and Legibility Diffuser sample from."""

    def __init__(self, config: DiffusionConfig, normalizer: Normalizer, task_space=None):
        super().__init__()
        if config.goal_offset and task_space is None:
            raise ValueError("goal_offset needs the task's kinematics (task_space)")
        self.config = config
        self.normalizer = normalizer
        self.task_space = task_space
        self.unet = ConditionalUnet1D(config.state_dim, config.global_cond_dim, config.down_dims,
                                      config.step_embed_dim, config.kernel_size, config.n_groups)
        self.alpha_bar = alphas_cumprod(config.num_train_timesteps, config.beta_schedule)  # (T,) the training ᾱ
        self.warm_skip = 0  # sampler steps a warm start skips (0: every chunk starts from noise)
        self._sampler = None  # (config, DDPMSteps or a diffusers scheduler)
        self._alpha_bar = None  # the training schedule's ᾱ on the device of the last loss
        self.placement = Placement()  # where the network runs (scdp.policies.placement; set by the loader, or place())
        self._graphs = GraphCache()
        self.sampler()  # built now, at load: a diffusers sampler's import is not a plan's time

    def place(self, where: Placement) -> "DiffusionPolicy":
        """Plan as ``where`` says (:func:`scdp.policies.placement.place`): the CUDA-graph switch, and the
        record of which denoiser the loader installed."""
        self.placement = where
        return self

    def use_sampler(self, sampler: str, steps: int) -> "DiffusionPolicy":
        """Plan with another sampler (``ddpm``, ``ddim``, ``dpmsolver``) at ``steps`` steps; no retraining
        is needed, the network predicts ε at any step. Validated like a config."""
        self.config = DiffusionConfig.from_dict({**self.config.to_dict(), "sampler": sampler, "num_inference_steps": steps})
        self.sampler()
        self._graphs = GraphCache()  # graphs are per step table
        return self

    def use_warm_start(self, skip: int) -> "DiffusionPolicy":
        """Start chunks from the previous plan, re-noised to step ``skip`` of the sampler's ``steps``
        (0: off). Refused unless 0 <= skip < steps."""
        if not 0 <= skip < self.config.num_inference_steps:
            raise ScdpError("--warm-skip", f"must be from 0 to {self.config.num_inference_steps - 1} (the sampler's "
                                           f"steps - 1), got {skip}")
        self.warm_skip = int(skip)
        return self

    @property
    def device(self) -> torch.device:
        """Where the network's weights are (see :mod:`scdp.devices`); the CPU for an exported network
        run by ONNX Runtime (:class:`scdp.policies.exported.OnnxDenoiser`), which holds none."""
        weights = next(self.unet.parameters(), None)
        return torch.device("cpu") if weights is None else weights.device

    # -- conditioning ----------------------------------------------------------------------
    def condition(self, state_n: torch.Tensor, goal_n: torch.Tensor | None, offset_n: torch.Tensor | None = None) -> torch.Tensor:
        """Scaled states (B, O, S), goal (B, G) and offsets (B, O, G) -> (B, O*(S+G[+G])).

        ``goal_n=None`` is the null goal: goal and offsets become zeros.
        """
        B, O, _ = state_n.shape  # noqa: E741 (O: n_obs_steps, as in the shape comments)
        if goal_n is None:
            goal_n = state_n.new_zeros(B, self.config.goal_dim)
            offset_n = state_n.new_zeros(B, O, self.config.goal_dim)
        parts = [state_n, goal_n[:, None].expand(B, O, -1)]
        if self.config.goal_offset:
            parts.append(offset_n)
        return torch.cat(parts, dim=-1).flatten(1)

    def _offset(self, goal: torch.Tensor, position: torch.Tensor) -> torch.Tensor | None:
        return self.normalizer.offset.normalize(goal[:, None] - position) if self.config.goal_offset else None

    def positions(self, state_hist: torch.Tensor) -> torch.Tensor:
        """Task-space points (B, O, G) of raw states (B, O, S), by the task's kinematics."""
        points = self.task_space(state_hist.detach().double().cpu().numpy())
        return torch.as_tensor(points, dtype=state_hist.dtype, device=state_hist.device)

    def observe(self, state_hist: torch.Tensor, goal: torch.Tensor | None, position: torch.Tensor | None = None) -> torch.Tensor:
        """Raw (B, O, S) states and (B, G) goal -> the global condition.

        ``position`` (B, O, G) may be passed when the caller already has :meth:`positions`.
        """
        state_n = self.normalizer.state.normalize(state_hist)
        if goal is None:
            return self.condition(state_n, None)
        offset = None
        if self.config.goal_offset:
            offset = self._offset(goal, self.positions(state_hist) if position is None else position)
        return self.condition(state_n, self.normalizer.goal.normalize(goal), offset)

    @property
    def captured_graphs(self) -> int:
        """How many CUDA graphs of the denoising loop this policy holds (one per kind of chunk planned)."""
        return len(self._graphs)

    @property
    def n_obs_steps(self) -> int:
        return self.config.n_obs_steps

    @property
    def n_action_steps(self) -> int:
        return self.config.n_action_steps

    @property
    def n_goals(self) -> int | None:
        return None  # the target is its only goal input

    @property
    def style_modes(self) -> tuple[str, ...]:
        return ()

    def set_style(self, style: str) -> None:
        raise ScdpError("style", f"{type(self).__name__} has no style to set; only SCDP does")

    @property
    def denoiser_parameters(self) -> int:
        return sum(p.numel() for p in self.unet.parameters())

    # -- training --------------------------------------------------------------------------
    def loss(self, batch: TrainBatch, film=None, generator: torch.Generator | None = None,
             x0_weight_cap: float = 1.0, min_step: int = 0) -> torch.Tensor:
        """ε-MSE on a batch of raw windows; ``film`` = (γ, β) at the bottleneck (style training).

        ``x0_weight_cap`` c > 1 weights each window's ε-MSE by ``clip(1 / SNR_k, 1, c)``
        (SNR_k = ᾱ_k / (1 - ᾱ_k)): where noise dominates, the loss moves towards the MSE of
        the clean-chunk estimate, which is where a sample's mode (the side of a path) is
        decided; an ε-MSE barely sees it there. c = 1 is the plain ε-MSE. Diffusion steps are
        drawn from ``min_step`` up (a style film that acts only there learns only there).
        """
        state_n = self.normalizer.state.normalize(batch.obs_state)
        goal_n = self.normalizer.goal.normalize(batch.goal)
        action = batch.action - batch.obs_state[:, -1:] if self.config.relative_actions else batch.action
        action_n = self.normalizer.action.normalize(action)
        B = action_n.shape[0]
        offset_n = self._offset(batch.goal, batch.obs_position) if self.config.goal_offset else None
        device = action_n.device  # every draw is made on the CPU generator, then moved (same draws on any device)
        if self.training and self.config.p_uncond > 0:  # goal dropout: the null goal is all zeros
            drop = upload(torch.rand(B, generator=generator) < self.config.p_uncond, device)
            goal_n = torch.where(drop[:, None], torch.zeros_like(goal_n), goal_n)
            if offset_n is not None:
                offset_n = torch.where(drop[:, None, None], torch.zeros_like(offset_n), offset_n)
        cond = self.condition(state_n, goal_n, offset_n)
        noise = upload(torch.randn(action_n.shape, generator=generator), device)
        k = upload(torch.randint(min_step, self.config.num_train_timesteps, (B,), generator=generator), device)
        noisy = add_noise(self._alphas_cumprod(device), action_n, noise, k)
        eps = self.unet(noisy, k, cond, film)
        if x0_weight_cap == 1.0:
            return F.mse_loss(eps, noise)
        alpha_bar = self._alphas_cumprod(device)[k]
        weight = ((1.0 - alpha_bar) / alpha_bar).clamp(1.0, x0_weight_cap)  # (B,)
        per_window = (eps - noise).pow(2).mean(dim=(1, 2))
        return (weight * per_window).sum() / weight.sum()

    def _alphas_cumprod(self, device: torch.device) -> torch.Tensor:
        """The training schedule's ᾱ on ``device``, copied there once."""
        if self._alpha_bar is None or self._alpha_bar.device != device:
            self._alpha_bar = self.alpha_bar.to(device)
        return self._alpha_bar

    # -- sampling --------------------------------------------------------------------------
    @torch.no_grad()
    def sample(self, cond: torch.Tensor, film=None, generator=None, eps_fn=None, film_from: int = 0,
               init: torch.Tensor | None = None, warm: torch.Tensor | None = None) -> torch.Tensor:
        """Denoise a (B, H, S) trajectory in scaled space, all B at once.

        ``generator`` is one CPU ``torch.Generator`` or a list of B (one per scene, so that a scene's
        noise does not depend on the batch it is planned in); the noise is drawn on the CPU and
        moved to ``cond``'s device, all of it before the loop (:func:`scdp.policies.sampling.draw_noise`).
        ``eps_fn(x, k, t) -> ε`` (``t`` the timestep as a Python int) replaces the plain network call (used
        for guidance). On a CUDA device the DDPM loop of the plain call runs as one CUDA graph
        (:mod:`scdp.policies.sampling`, when :attr:`placement` says so). ``film`` acts at the
        steps k >= ``film_from`` only. ``init`` (B, H, S) scaled and ``warm`` (B,) bool: the scenes
        that start from ``init`` re-noised to step ``warm_skip`` (when every scene does, the first
        ``warm_skip`` steps are not run at all).
        """
        B = cond.shape[0]
        shape = (B, self.config.horizon, self.config.state_dim)
        sampler = self.sampler()
        fast = sampler if isinstance(sampler, DDPMSteps) else None  # DDPM: its steps with their constants computed once
        timesteps = sampler.timesteps
        skip = self.warm_skip if warm is not None and bool(warm.any()) else 0
        all_warm = bool(skip) and bool(warm.all())
        run = [i for i in range(len(timesteps)) if not (all_warm and i < skip)]  # all warm: skipped, never run
        x, noises = draw_noise(shape, generator, fast, run, cond.device)  # every draw first, in one upload
        chunk = Denoising(x, cond, film, film_from, run, noises)
        if skip:
            t_skip = timesteps[skip].expand(B).to(x.device)
            chunk.skip, chunk.rows = skip, warm.to(x.device)[:, None, None]
            chunk.renoised = add_noise(self._alphas_cumprod(x.device), init.to(x.device), x, t_skip)
        if self.placement.replays(x.device.type, plain_ddpm=fast is not None and eps_fn is None):
            return self._graphs.denoise(self.unet, fast, chunk)  # the same loop, replayed from one CUDA graph
        eps = network_eps(self.unet, chunk, timesteps) if eps_fn is None else guided_eps(eps_fn, timesteps, B, x.device)
        return denoise(chunk, eps, scheduler_step(sampler, generator))

    def sampler(self):
        """What denoises at planning time, for the current config: :class:`DDPMSteps` for DDPM,
        :class:`DDIMSteps` for DDIM, else the diffusers scheduler (DPM-Solver) with its timesteps set;
        built once per config."""
        if self._sampler is None or self._sampler[0] is not self.config:  # a new config is a new object (frozen)
            c = self.config
            own = OWN_STEPS.get(c.sampler)
            if own is not None:
                sampler = own(c.num_train_timesteps, c.beta_schedule, c.clip_sample, c.num_inference_steps)
            else:
                sampler = importlib.import_module(DIFFUSERS_SAMPLERS).make_sampler(c)
            self._sampler = (c, sampler)
        sampler = self._sampler[1]
        if not isinstance(sampler, StepTable):
            sampler.set_timesteps(self.config.num_inference_steps)  # a multistep solver restarts its history here
        return sampler

    # -- warm starts -------------------------------------------------------------------------
    def warm_starts(self, warm: WarmStart | None, state_hist: torch.Tensor, weights=None) -> list[str]:
        """How each scene's next chunk starts: ``warm``, or why it starts cold (``off``, ``first``,
        ``dropped``, ``style``, ``jump``). ``state_hist`` (B, O, S) raw; ``weights`` (B,) this chunk's
        legible weights (None: no style)."""
        B = state_hist.shape[0]
        if not self.warm_skip:
            return ["off"] * B
        if warm is None or warm.plan is None:
            return [(warm.cold[i] if warm is not None else None) or "first" for i in range(B)]
        starts = [reason or "warm" for reason in warm.cold]
        if weights is not None and warm.weights is not None:
            moved = np.abs(np.asarray(weights, dtype=np.float64) - warm.weights) > STYLE_TOLERANCE
            starts = ["style" if m and s == "warm" else s for s, m in zip(starts, moved)]
        expected = warm.plan[:, min(self.config.n_obs_steps - 2 + warm.executed, self.config.horizon - 1)]
        scale = self.normalizer.state.normalize
        off = (scale(state_hist[:, -1].cpu().float()) - scale(expected.float())).abs().amax(dim=-1)
        return ["jump" if s == "warm" and bool(o > JUMP_TOLERANCE) else s for s, o in zip(starts, off)]

    def warm_init(self, warm: WarmStart, state_hist: torch.Tensor) -> torch.Tensor:
        """The previous plans shifted by the actions taken since (the last row repeated), as this
        chunk's scaled actions: (B, H, S)."""
        H, e = self.config.horizon, warm.executed
        rows = torch.clamp(torch.arange(H) + e, max=H - 1)
        shifted = warm.plan[:, rows].to(state_hist.device, state_hist.dtype)  # absolute states
        action = shifted - state_hist[:, -1:] if self.config.relative_actions else shifted
        return self.normalizer.action.normalize(action)

    def warm_args(self, warm: WarmStart | None, state_hist: torch.Tensor, weights=None) -> tuple[dict, list[str]]:
        """``sample``'s ``init`` and ``warm`` for these scenes, and their starts."""
        starts = self.warm_starts(warm, state_hist, weights)
        if "warm" not in starts:
            return {}, starts
        rows = torch.tensor([s == "warm" for s in starts])
        return {"init": self.warm_init(warm, state_hist), "warm": rows}, starts

    def plan_states(self, x_n: torch.Tensor, state_hist: torch.Tensor) -> torch.Tensor:
        """Scaled (B, H, S) plan -> the whole horizon as absolute states, on the CPU."""
        plan = self.normalizer.action.unnormalize(x_n)
        return (plan + state_hist[:, -1:] if self.config.relative_actions else plan).cpu()

    def actions_to_execute(self, x_n: torch.Tensor, state_hist: torch.Tensor) -> torch.Tensor:
        """Scaled (B, H, S) plan -> the absolute next states to execute now, (B, n_action_steps, S)."""
        start = self.config.n_obs_steps - 1
        actions = self.normalizer.action.unnormalize(x_n[:, start:start + self.config.n_action_steps])
        return actions + state_hist[:, -1:] if self.config.relative_actions else actions

    def act(self, obs: Observation, generator=None, warm: WarmStart | None = None) -> Chunk:
        """Plain goal-conditioned sampling (no style)."""
        obs = obs.to(self.device)
        start, starts = self.warm_args(warm, obs.state_hist)
        plan = self.sample(self.observe(obs.state_hist, obs.goal), generator=generator, **start)
        return Chunk(self.actions_to_execute(plan, obs.state_hist).cpu(), ["none"] * len(obs.target),
                     plan=self.plan_states(plan, obs.state_hist), starts=starts)

    def reset(self) -> None:
        """Nothing to reset: the plain policy has no per-episode state."""
