"""Data-parallel training under Hugging Face Accelerate: two CPU processes (gloo), same checkpoint layout.

`--multi_gpu` is accelerate's name for torchrun-style processes; without a GPU they talk over gloo.
"""

import json
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import torch

from scdp.policies.base import observe_histories
from scdp.policies.loaders import load_diffusion
from scdp.tasks import NAVIGATION


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


HELPER = Path(__file__).parent / "helpers" / "dp_regression.py"


def launch() -> list[str]:
    return [sys.executable, "-m", "accelerate.commands.launch", "--multi_gpu", "--num_processes", "2", "--num_machines", "1",
            "--mixed_precision", "no", "--dynamo_backend", "no", "--main_process_port", str(free_port())]


def test_two_processes_step_with_the_gradient_of_the_whole_batch(tmp_path):
    """Each process takes half of every batch; averaging their gradients must give the step one process
    takes on the whole batch. Checked by deleting the ``accelerator.reduce`` line in
    ``scdp.training.loop.train``: the two ranks then drift apart and from the single process (this
    test fails), while the checkpoint test below still passes."""
    single = subprocess.run([sys.executable, str(HELPER), str(tmp_path / "one")], capture_output=True, text=True, timeout=300)
    assert single.returncode == 0, single.stderr[-3000:]
    double = subprocess.run(launch() + [str(HELPER), str(tmp_path / "two")], capture_output=True, text=True, timeout=300)
    assert double.returncode == 0, double.stderr[-3000:]
    weights = [json.loads(p.read_text()) for p in (tmp_path / "one" / "rank0.json", tmp_path / "two" / "rank0.json",
                                                   tmp_path / "two" / "rank1.json")]
    # each process's group is closed by the loop before it returns: left open until exit, gloo can
    # abort a process at exit (SIGABRT) beside a busy core (removing end_training() fails this)
    assert [w.pop("group_open_after_train") for w in weights] == [False, False, False]
    reference = {k: np.array(v) for k, v in weights[0].items()}
    torch.manual_seed(0)  # the helper's initial weights: training must have moved them
    start = {k: v.detach().numpy() for k, v in torch.nn.Linear(3, 2).state_dict().items()}
    assert all(np.abs(reference[k] - start[k]).max() > 1e-2 for k in reference)
    for other in weights[1:]:
        for k, v in other.items():
            np.testing.assert_allclose(np.array(v), reference[k], rtol=1e-5, atol=1e-6)


def test_two_processes_train_one_checkpoint(tiny_reproduction, tmp_path):
    out = tmp_path / "base"
    train = ["-m", "scdp", "train", "base", "--task", "navigation", "--preset", "tiny", "--set", "base.train.epochs=2",
             "--data", str(tiny_reproduction / "navigation" / "demos.zarr"), "--out", str(out)]
    done = subprocess.run(launch() + train, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    meta = json.loads((out / "config.json").read_text())
    state = json.loads((out / "train_state.json").read_text())
    assert meta["complete"] and meta["part"] == "base" and (out / "model.safetensors").exists()
    assert state["job"]["processes"] == 2 and state["step"] == state["total_steps"]
    assert sorted(p.name for p in out.iterdir()) == ["config.json", "inputs.json", "model.safetensors", "train_state.json",
                                                     "train_state.safetensors"]
    policy = load_diffusion(out, NAVIGATION)  # the checkpoint plans like any other
    obs = observe_histories(NAVIGATION, [np.zeros((1, 3))], [[[2.0, 0.3], [2.0, -0.3]]], [0], policy.n_obs_steps)
    actions = policy.act(obs, [torch.Generator().manual_seed(0)]).actions
    assert actions.shape == (1, policy.config.n_action_steps, 3) and torch.isfinite(actions).all()
