"""scdp.policies.noise_schedule, DDPMSteps and DDIMSteps hold diffusers' DDPM and DDIM numbers bit for bit, without importing diffusers.

Every beta schedule a config allows, at training lengths and step counts the presets use and odd ones:
ᾱ, the timesteps, the forward noising, each reverse step's constants, and the noise draws (one
generator, or one per scene) are compared with ``diffusers.DDPMScheduler`` and ``randn_tensor``.
"""

import pytest
import torch
from diffusers import DDIMScheduler, DDPMScheduler
from diffusers.utils.torch_utils import randn_tensor

from scdp.config import DiffusionConfig
from scdp.errors import ScdpError
from scdp.keys import BETA_SCHEDULES
from scdp.policies import noise_schedule
from scdp.policies.ddim_steps import DDIMSteps
from scdp.policies.ddpm_steps import DDPMSteps, randn


@pytest.mark.parametrize("schedule", BETA_SCHEDULES)
@pytest.mark.parametrize("T", [100, 1000, 37])
def test_alphas_cumprod_are_diffusers(schedule, T):
    reference = DDPMScheduler(num_train_timesteps=T, beta_schedule=schedule).alphas_cumprod
    assert torch.equal(noise_schedule.alphas_cumprod(T, schedule), reference)


@pytest.mark.parametrize("T,steps", [(100, 8), (100, 100), (100, 1), (100, 3), (1000, 7), (37, 5)])
def test_ddpm_timesteps_are_diffusers(T, steps):
    scheduler = DDPMScheduler(num_train_timesteps=T)
    scheduler.set_timesteps(steps)
    assert torch.equal(noise_schedule.ddpm_timesteps(T, steps), scheduler.timesteps)


@pytest.mark.parametrize("schedule", BETA_SCHEDULES)
def test_add_noise_is_diffusers(schedule):
    g = torch.Generator().manual_seed(0)
    x0, noise = torch.randn(6, 16, 3, generator=g), torch.randn(6, 16, 3, generator=g)
    k = torch.randint(0, 100, (6,), generator=g)
    scheduler = DDPMScheduler(num_train_timesteps=100, beta_schedule=schedule)
    mine = noise_schedule.add_noise(noise_schedule.alphas_cumprod(100, schedule), x0, noise, k)
    assert torch.equal(mine, scheduler.add_noise(x0, noise, k))


@pytest.mark.parametrize("schedule", BETA_SCHEDULES)
@pytest.mark.parametrize("clip", [True, False])
@pytest.mark.parametrize("steps", [8, 10, 100])
def test_every_reverse_step_is_the_schedulers(schedule, clip, steps):
    """Each step of DDPMSteps, with its noise drawn from the same generator, is DDPMScheduler.step's result."""
    scheduler = DDPMScheduler(num_train_timesteps=100, beta_schedule=schedule, clip_sample=clip)
    scheduler.set_timesteps(steps)
    fast = DDPMSteps(100, schedule, clip, steps)
    g = torch.Generator().manual_seed(steps)
    x = torch.randn(4, 16, 3, generator=g) * 2  # beyond [-1, 1]: the clip matters
    for i, t in enumerate(scheduler.timesteps):
        eps = torch.randn(4, 16, 3, generator=g)
        a = fast.step(i, eps, x, generator=torch.Generator().manual_seed(i))
        b = scheduler.step(eps, t, x, generator=torch.Generator().manual_seed(i)).prev_sample
        assert torch.equal(a, b), (i, int(t))
        x = b
    assert [fast.adds_noise(i) for i in range(steps)] == [True] * (steps - 1) + [False]


@pytest.mark.parametrize("per_scene", [False, True])
def test_noise_draws_are_randn_tensors(per_scene):
    make = (lambda: [torch.Generator().manual_seed(s) for s in (3, 4, 5)]) if per_scene else (lambda: torch.Generator().manual_seed(3))
    assert torch.equal(randn((3, 16, 2), make()), randn_tensor((3, 16, 2), generator=make(), device=torch.device("cpu")))


def test_an_unknown_beta_schedule_is_refused_by_name():
    with pytest.raises(ScdpError, match="beta_schedule: one of linear, scaled_linear, squaredcos_cap_v2, got 'cosine'"):
        DiffusionConfig(state_dim=3, goal_dim=2, beta_schedule="cosine")
    with pytest.raises(ScdpError, match="beta_schedule"):
        noise_schedule.betas(10, "cosine")


@pytest.mark.parametrize("schedule", BETA_SCHEDULES)
@pytest.mark.parametrize("clip", [True, False])
@pytest.mark.parametrize("steps", [2, 8, 20, 3])
def test_every_ddim_step_is_the_schedulers(schedule, clip, steps):
    """Each step of DDIMSteps is DDIMScheduler.step's result (η = 0), bit for bit, on the same timesteps."""
    scheduler = DDIMScheduler(num_train_timesteps=100, beta_schedule=schedule, clip_sample=clip, prediction_type="epsilon")
    scheduler.set_timesteps(steps)
    own = DDIMSteps(100, schedule, clip, steps)
    assert torch.equal(own.timesteps, scheduler.timesteps)
    g = torch.Generator().manual_seed(steps)
    x = torch.randn(4, 16, 3, generator=g) * 2  # beyond [-1, 1]: the clip matters
    for i, t in enumerate(scheduler.timesteps):
        eps = torch.randn(4, 16, 3, generator=g)
        b = scheduler.step(eps, t, x).prev_sample
        assert torch.equal(own.step(i, eps, x), b), (i, int(t))
        x = b
    assert not any(own.adds_noise(i) for i in range(steps))
