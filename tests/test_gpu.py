"""On a CUDA GPU (marker ``gpu``; each test is skipped, with the reason, where torch sees none, as on
CI): every planner plans on the GPU what it plans on the CPU, the DDPM loop replayed from a CUDA graph
plans what the eager loop plans, a few training steps run there in TF32, and ``evaluate`` and the
planning service take ``--device cuda``. They read the committed cpu checkpoints: no training first.

Tolerances: the same noise is drawn on the CPU for both devices, so plans differ only by float32
rounding in different kernels, carried through the denoising steps: 1e-3 in state units (metres,
radians) between the devices, 1e-4 between the graph and the eager loop on one GPU."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch
from fastapi.testclient import TestClient

from scdp.cli import main
from scdp.config import PlanningOptions
from scdp.policies.base import WarmStart, act, observe_histories
from scdp.policies.loaders import load_diffusion, load_method
from scdp.serve.app import PlanningService, create_app
from scdp.tasks import get_task
from scdp.training import parts
from scdp.training.loop import TrainResult

pytestmark = pytest.mark.gpu
ROOT = Path(__file__).parents[1]
METHODS = ("dp", "ld", "scdp", "scdp_legible", "scdp_efficient", "scdp_blend")
DEVICE_TOLERANCE, GRAPH_TOLERANCE = 1e-3, 1e-4
SCENES = {"navigation": ([[2.0, 0.3], [2.0, -0.3]], [[1.6, 0.1], [1.8, -0.5]], [[2.2, 0.0], [1.5, 0.6]]),
          "block_reach": ([[0.5, 0.15, 0.1], [0.5, -0.15, 0.1]], [[0.45, 0.05, 0.1], [0.6, -0.2, 0.1]],
                          [[0.55, 0.25, 0.1], [0.4, -0.1, 0.1]])}


def checkpoints(task: str) -> Path:
    return ROOT / "results" / "cpu" / task / "checkpoints"


def observation(task, planner):
    """Three scenes of ``task`` at the start state, one generator each (same draws on every device)."""
    goals = SCENES[task.name]
    start = task.nominal_start()
    obs = observe_histories(task, [[start]] * 3, goals, [0, 1, 0], planner.n_obs_steps)
    return obs, [torch.Generator().manual_seed(s) for s in range(3)]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("task_name", ["navigation", "block_reach"])
def test_every_planner_plans_on_the_gpu_what_it_plans_on_the_cpu(task_name, method):
    task = get_task(task_name)
    chunks = []
    for device in ("cpu", "cuda"):
        planner = load_method(method, checkpoints(task_name), task, PlanningOptions(device=device, runtime="torch"))
        obs, generators = observation(task, planner)
        chunks.append(act(planner, obs, generators))
    cpu, cuda = chunks
    assert cuda.actions.device.type == "cpu" and cuda.styles == cpu.styles  # chunks come back on the CPU
    assert torch.allclose(cpu.actions, cuda.actions, atol=DEVICE_TOLERANCE), (cpu.actions - cuda.actions).abs().max()


@pytest.mark.parametrize("method", ["dp", "scdp", "scdp_legible"])
def test_the_graph_replayed_loop_plans_what_the_eager_loop_plans(method):
    """Cold and warm chunks (the warm start re-noises the previous plan inside the graph), three
    scenes padded to a batch of four: the graph's plans equal the eager loop's, and graphs were captured."""
    task = get_task("navigation")
    options = PlanningOptions(device="cuda", sampler="ddpm", steps=8, warm_skip=4, runtime="torch")
    planners = [load_method(method, checkpoints("navigation"), task, replace(options, cuda_graphs=graphs))
                for graphs in ("on", "off")]
    bases = [getattr(p, "base", p) for p in planners]
    plans = []
    for planner in planners:
        obs, generators = observation(task, planner)
        first = act(planner, obs, generators)
        # the robots followed the first chunk exactly: the next one starts warm from its plan
        moved = [[task.nominal_start(), *first.actions[b].double().numpy()] for b in range(3)]
        after = observe_histories(task, moved, SCENES["navigation"], [0, 1, 0], planner.n_obs_steps)
        second = act(planner, after, generators, WarmStart.from_chunk(first, planner.n_action_steps))
        assert "warm" in second.starts  # (a scene whose plan's first step is off the state starts cold: "jump")
        plans.append((first.actions, second.actions, second.starts))
    assert bases[0].captured_graphs == 2 and bases[1].captured_graphs == 0  # the cold and the warm loop
    assert plans[0][2] == plans[1][2]
    for graph, eager in zip(plans[0][:2], plans[1][:2]):
        assert torch.allclose(graph, eager, atol=GRAPH_TOLERANCE), (graph - eager).abs().max()


def test_a_few_training_steps_run_on_the_gpu_in_tf32(tmp_path):
    from helpers.tiny import TINY
    from scdp.data.generate import generate_demos

    task = get_task("navigation")
    data, _ = generate_demos(task, 6, seed=3, progress=False)
    _, result = parts.train_diffusion(task, data, TINY.with_overrides(["base.train.min_steps=30"]), tmp_path / "base",
                                      progress=False, device="cuda")
    assert isinstance(result, TrainResult) and result.precision == "tf32" and result.steps >= 30
    assert all(np.isfinite(result.losses))
    assert json.loads((tmp_path / "base" / "train_state.json").read_text())["precision"] == "tf32"
    assert not torch.backends.cuda.matmul.allow_tf32  # planning afterwards keeps full float32
    policy = load_diffusion(tmp_path / "base", task)  # the GPU-trained checkpoint loads and plans on the CPU
    obs, generators = observation(task, policy)
    assert torch.isfinite(act(policy, obs, generators).actions).all()


def test_evaluate_and_serve_run_on_the_gpu(tmp_path, capsys):
    assert main(["evaluate", "--task", "navigation", "--checkpoints", str(checkpoints("navigation")), "--scenes", "2",
                 "--methods", "dp", "scdp", "--device", "cuda", "--out", str(tmp_path / "eval.json")]) == 0
    records = json.loads((tmp_path / "eval.json").read_text())
    assert records
    service = PlanningService(checkpoints("navigation"), "navigation", methods=("dp", "scdp"), planning=PlanningOptions(device="cuda"))
    with TestClient(create_app(service)) as client:
        body = {"state_history": [[0.0, 0.0, 0.0]], "goals": [[2.0, 0.3], [2.0, -0.3]], "target": 0, "method": "scdp", "seed": 1}
        answer = client.post("/v1/act", json=body)
    assert answer.status_code == 200, answer.text
    assert np.isfinite(np.asarray(answer.json()["actions"])).all()


def _scene_obs(task, planner, n: int):
    """The first ``n`` of SCENES[task] at the start state, one seeded generator each."""
    goals = list(SCENES[task.name])[:n]
    targets = [0, 1, 0][:n]
    obs = observe_histories(task, [[task.nominal_start()]] * n, goals, targets, planner.n_obs_steps)
    return obs, goals, targets, [torch.Generator().manual_seed(s) for s in range(n)]


def _churn() -> None:
    """Allocate and free enough device memory that any block a graph's input lost goes to someone else."""
    junk = [torch.full((1 << 18,), float("nan"), device="cuda") for _ in range(256)]
    del junk
    torch.cuda.synchronize()


@pytest.mark.parametrize("task_name", ["navigation", "block_reach"])
@pytest.mark.parametrize("steps, warm_skip", [(20, 0), (8, 4)])  # the trained sampler, the fast planner
def test_graphs_keep_planning_what_the_eager_loop_plans_after_memory_is_reused(task_name, steps, warm_skip):
    """Every graph kind (cold and warm; batch 1, and 3 scenes padded to 4) replayed three times, other
    graphs in between, the allocator's freed memory filled with NaN between rounds: each replay
    plans what the eager loop plans. (A graph whose timestep table was a freed local read NaN here.)"""
    task = get_task(task_name)
    options = PlanningOptions(device="cuda", sampler="ddpm", steps=steps, warm_skip=warm_skip, runtime="torch")
    graphed, eager = (load_method("dp", checkpoints(task_name), task, replace(options, cuda_graphs=graphs))
                      for graphs in ("on", "off"))
    for _ in range(3):
        for n in (1, 3):
            plans = []
            for planner in (graphed, eager):
                obs, goals, targets, generators = _scene_obs(task, planner, n)
                first = act(planner, obs, generators)
                moved = [[task.nominal_start(), *first.actions[b].double().numpy()] for b in range(n)]
                after = observe_histories(task, moved, goals, targets, planner.n_obs_steps)
                second = act(planner, after, generators, WarmStart.from_chunk(first, planner.n_action_steps))
                plans.append((first.actions, second.actions))
                _churn()
            for graph, eager_plan in zip(*plans):
                assert torch.isfinite(graph).all()
                assert torch.allclose(graph, eager_plan, atol=GRAPH_TOLERANCE), (graph - eager_plan).abs().max()
    assert graphed.captured_graphs >= 2 and eager.captured_graphs == 0
