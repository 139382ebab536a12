"""Where the network runs is decided in one place (scdp.policies.placement.place), every planner runs
the one denoising loop (scdp.policies.sampling.denoise), and docs/speed.md's table is the code's."""

import re
from pathlib import Path

import numpy as np
import pytest
import torch

from scdp.config import PlanningOptions
from scdp.policies import sampling
from scdp.policies.loaders import load_method
from scdp.policies.placement import Placement, place, placement_table
from scdp.tasks import NAVIGATION

DOC = Path(__file__).parents[1] / "docs" / "speed.md"


def test_docs_speed_table_is_the_placement_the_code_decides():
    found = re.search(r"<!-- placement_table -->\n(.*?)\n<!-- /placement_table -->", DOC.read_text(), re.S)
    assert found is not None and found[1] == placement_table()


@pytest.mark.parametrize("runtime, device, graphs, exported, want", [
    ("onnx", "cuda", True, True, Placement("onnx", "cpu", False)),  # the graph runs on the CPU, whatever the device
    ("auto", "cpu", True, True, Placement("auto", "cpu", False)),
    ("auto", "cpu", True, False, Placement("torch", "cpu", True)),  # nothing exported: torch
    ("auto", "cuda", False, True, Placement("torch", "cuda", False)),  # a GPU: torch, the switch as given
    ("torch", "cuda", True, True, Placement("torch", "cuda", True)),
])
def test_place_decides_the_denoiser_and_the_graph_switch(runtime, device, graphs, exported, want):
    assert place(runtime, device, graphs, exported) == want


def test_only_a_plain_ddpm_loop_of_the_torch_network_on_a_gpu_replays_a_graph():
    on_gpu = Placement("torch", "cuda", True)
    assert on_gpu.replays("cuda", plain_ddpm=True)
    assert not on_gpu.replays("cuda", plain_ddpm=False)  # guidance, DDIM, DPM-Solver: eager
    assert not on_gpu.replays("cpu", plain_ddpm=True)
    assert not Placement("torch", "cuda", False).replays("cuda", plain_ddpm=True)  # --cuda-graphs off


@pytest.mark.parametrize("sampler", ["ddpm", "ddim"])
@pytest.mark.parametrize("warm", [False, True])
def test_a_planner_s_own_call_that_is_the_plain_call_plans_the_same_bit_for_bit(tiny_ckpt, sampler, warm, monkeypatch):
    """One loop for every call: handing ``sample`` the plain network call as a planner's own
    (``eps_fn``, the path LD's and SCDP's guidance take) plans exactly what the plain call plans,
    cold and warm, for DDPM and DDIM, and the loop runs once per step either way."""
    dp = load_method("dp", tiny_ckpt, NAVIGATION, PlanningOptions(sampler=sampler, steps=6, warm_skip=3, runtime="torch"))
    cond = torch.randn(3, dp.config.global_cond_dim, generator=torch.Generator().manual_seed(5))
    start = {}
    if warm:
        init = torch.randn(3, dp.config.horizon, dp.config.state_dim, generator=torch.Generator().manual_seed(6))
        start = {"init": init, "warm": torch.tensor([True, False, True])}
    loops = []
    real = sampling.denoise
    monkeypatch.setattr("scdp.policies.diffusion.denoise", lambda *a: loops.append(1) or real(*a))

    def gens():
        return [torch.Generator().manual_seed(i) for i in range(3)]

    plain = dp.sample(cond, generator=gens(), **start)
    own = dp.sample(cond, generator=gens(), eps_fn=lambda x, k, t: dp.unet(x, k, cond), **start)
    assert torch.equal(plain, own) and not torch.equal(plain, dp.sample(cond * 1.01, generator=gens(), **start))
    assert len(loops) == 3
    assert np.isfinite(plain.numpy()).all()
