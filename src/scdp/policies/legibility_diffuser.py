"""Legibility Diffuser (baseline): guidance away from the distractors, as the authors reproduced it.

The base policy is trained with goal dropout (``GuidanceConfig.p_uncond``, null goal = zeros). At every
denoising step the noise estimate is

    ε̃ = (1 + w) ε(g*) − α w ε(g⁻) − (1 − α) w ε(∅)

(with several distractors, ε(g⁻) is their mean). The three (or 2 + N) estimates come from
one batched forward pass. The weights sum to 1. After each executed chunk ``w ← λ w``:
λ decays over replanning steps, not over denoising steps. With ``GuidanceConfig.window`` < 1 the
guidance acts over the noisiest fraction of the denoising steps only (ε(g*) alone below), the
same lever SCDP's film has (``StyleConfig.noise_window``). The authors' values
(:class:`~scdp.config.GuidanceConfig`): w₀ = 4.5, α = 0.9, λ = 0.5.
"""

from __future__ import annotations

import torch

from scdp.config import GuidanceConfig, first_step_of_window
from scdp.errors import ScdpError
from scdp.policies.base import Chunk, Observation, WarmStart
from scdp.policies.diffusion import DiffusionPolicy


def guidance_weights(w: float, alpha: float) -> tuple[float, float, float]:
    """Coefficients of ε(g*), ε(g⁻), ε(∅). They sum to 1 for any w and α."""
    return 1.0 + w, -alpha * w, -(1.0 - alpha) * w


class LegibilityDiffuser:
    """Method ``ld``: wraps a goal-dropout-trained :class:`DiffusionPolicy`; a
    :class:`~scdp.policies.base.Planner`."""

    def __init__(self, policy: DiffusionPolicy, guidance: GuidanceConfig = GuidanceConfig()):
        self.policy = policy
        self.guidance = guidance
        self.w = guidance.w0

    @property
    def n_obs_steps(self) -> int:
        return self.policy.n_obs_steps

    @property
    def n_action_steps(self) -> int:
        return self.policy.n_action_steps

    @property
    def n_goals(self) -> int | None:
        return None  # every other goal is a negative condition, whatever their number

    @property
    def style_modes(self) -> tuple[str, ...]:
        return ()

    def set_style(self, style: str) -> None:
        raise ScdpError("style", f"{type(self).__name__} has no style to set; only SCDP does")

    @property
    def denoiser_parameters(self) -> int:
        return self.policy.denoiser_parameters

    def reset(self) -> None:
        """Start of an episode (batch): the guidance weight goes back to w₀."""
        self.w = self.guidance.w0

    def act(self, obs: Observation, generator=None, warm: WarmStart | None = None) -> Chunk:
        p = self.policy
        obs = obs.to(p.device)
        state_hist, goals, target = obs.state_hist, obs.goals, obs.target
        B, K, _ = goals.shape
        rows = torch.arange(B, device=goals.device)
        others = torch.stack([torch.cat([goals[b, :target[b]], goals[b, target[b] + 1:]]) for b in range(B)])  # (B, K-1, G)
        position = p.positions(state_hist) if p.config.goal_offset else None  # one FK for all conditions
        conds = [p.observe(state_hist, goals[rows, target], position)]
        conds += [p.observe(state_hist, others[:, i], position) for i in range(K - 1)]
        conds.append(p.observe(state_hist, None))
        stacked = torch.cat(conds)  # ((K + 1) B, cond)
        if obs.chunk_index is None:  # an episode this object follows: w decays once per chunk it plans
            w = self.w
        else:  # a caller that keeps no episode (the service) says each scene's chunk: w = w0 decay^k
            w = (self.guidance.w0 * self.guidance.decay ** obs.chunk_index.double()).float()[:, None, None]
        c_pos, c_neg, c_null = guidance_weights(w, self.guidance.alpha)
        first_guided = first_step_of_window(self.guidance.window, p.config.num_train_timesteps)

        def eps_fn(x, k, t):
            if t < first_guided:  # below the window: the conditional estimate alone
                return p.unet(x, k, stacked[:B])
            eps = p.unet(x.repeat(K + 1, 1, 1), k.repeat(K + 1), stacked).reshape(K + 1, B, *x.shape[1:])
            return c_pos * eps[0] + c_neg * eps[1:K].mean(0) + c_null * eps[K]

        start, starts = p.warm_args(warm, state_hist)
        plan = p.sample(stacked[:B], generator=generator, eps_fn=eps_fn, **start)
        if obs.chunk_index is None:
            self.w *= self.guidance.decay  # once per executed chunk
        return Chunk(p.actions_to_execute(plan, state_hist).cpu(), ["none"] * B, plan=p.plan_states(plan, state_hist),
                     starts=starts)
