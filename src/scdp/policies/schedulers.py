"""diffusers' schedulers on the training schedule: DPM-Solver++ for planning, DDPM and DDIM for reference.

This module is imported by name, on the first plan with DPM-Solver
(:meth:`scdp.policies.diffusion.DiffusionPolicy.use_sampler` or a saved ``sampler``), never at
start-up: importing diffusers imports ``torch._dynamo``, and DDPM and DDIM, which scdp steps itself
(:mod:`scdp.policies.ddpm_steps`, :mod:`scdp.policies.ddim_steps`), need none of it. ``make_sampler``
also builds diffusers' own DDPM and DDIM, which the tests hold scdp's steps against.
"""

from __future__ import annotations

import diffusers

from scdp.config import DiffusionConfig


def make_sampler(config: DiffusionConfig):
    """The diffusers scheduler for ``config.sampler``: DDPM, DDIM (deterministic, eta = 0) or
    DPM-Solver++ (2nd-order multistep), all on the training schedule."""
    common = dict(num_train_timesteps=config.num_train_timesteps, beta_schedule=config.beta_schedule,
                  prediction_type="epsilon")
    if config.sampler == "dpmsolver":  # clip_sample's counterpart: thresholding at 1 clips the x0 estimate to [-1, 1]
        return diffusers.DPMSolverMultistepScheduler(**common, algorithm_type="dpmsolver++", solver_order=2,
                                                     thresholding=config.clip_sample, sample_max_value=1.0)
    ddpm_or_ddim = diffusers.DDPMScheduler if config.sampler == "ddpm" else diffusers.DDIMScheduler
    return ddpm_or_ddim(**common, clip_sample=config.clip_sample)
