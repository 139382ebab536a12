"""``--device``: names resolve, a missing GPU is refused by field, planners hand chunks back on the CPU."""

import pytest
import torch

from scdp import devices
from scdp.cli import main
from scdp.config import PlanningOptions
from scdp.errors import ScdpError
from scdp.policies.base import observe_histories
from scdp.policies.loaders import load_diffusion
from scdp.tasks import NAVIGATION


@pytest.fixture
def no_gpu(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


@pytest.fixture
def two_gpus(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 2)


def test_auto_is_the_cpu_without_a_gpu(no_gpu):
    assert devices.resolve("auto") == torch.device("cpu")
    assert devices.resolve(None) == torch.device("cpu")
    assert devices.resolve("CPU") == torch.device("cpu")


def test_auto_takes_the_gpu_when_there_is_one(two_gpus):
    assert devices.resolve("auto") == torch.device("cuda")
    assert devices.resolve("cuda:1") == torch.device("cuda", 1)


@pytest.mark.parametrize("spec, words", [("gpu", "unknown device"), ("cuda:x", "unknown device"), ("mps:0", "unknown device"),
                                         ("cuda", "no CUDA GPU"), ("cuda:0", "no CUDA GPU")])
def test_bad_or_missing_devices_are_refused_by_field(no_gpu, spec, words):
    with pytest.raises(ScdpError) as err:
        devices.resolve(spec)
    assert err.value.field == "--device" and words in err.value.message


def test_a_gpu_index_beyond_the_count_is_refused(two_gpus):
    with pytest.raises(ScdpError, match="sees 2 GPU"):
        devices.resolve("cuda:2")


def test_cli_refuses_cuda_on_a_cpu_machine_in_one_line(no_gpu, tmp_path, capsys):
    code = main(["train", "encoder", "--task", "navigation", "--preset", "tiny", "--out", str(tmp_path / "enc"),
                 "--device", "cuda"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("scdp: error: --device:")
    assert not (tmp_path / "enc").exists()


def test_observation_moves_whole(no_gpu):
    obs = observe_histories(NAVIGATION, [[[0.0, 0.0, 0.0]]], [[[2.0, 0.2], [2.0, -0.2]]], [1], 2)
    moved = obs.to(devices.resolve("cpu"))
    for name in ("state_hist", "position", "goals", "target"):
        assert torch.equal(getattr(moved, name), getattr(obs, name))
    assert torch.allclose(moved.goal, torch.tensor([[2.0, -0.2]]))


def test_observation_moves_every_field_to_another_device_kind():
    """``meta`` (shapes without storage) is a second device kind that every torch build has, so this
    runs everywhere: moving to the CPU it already is on could not show a field left behind."""
    obs = observe_histories(NAVIGATION, [[[0.0, 0.0, 0.0]]], [[[2.0, 0.2], [2.0, -0.2]]], [1], 2)
    moved = obs.to(torch.device("meta"))
    for name in ("state_hist", "position", "goals", "target"):
        assert getattr(moved, name).device.type == "meta", name
        assert getattr(moved, name).shape == getattr(obs, name).shape
        assert getattr(obs, name).device.type == "cpu"  # the original is not changed


@pytest.mark.gpu
def test_a_planner_on_the_gpu_plans_what_it_plans_on_the_cpu(tiny_reproduction):
    folder = tiny_reproduction / "navigation" / "checkpoints" / "base"
    obs = observe_histories(NAVIGATION, [[[0.0, 0.0, 0.0]]], [[[2.0, 0.2], [2.0, -0.2]]], [0], 2)
    chunks = [load_diffusion(folder, NAVIGATION, planning=PlanningOptions(device=d)).act(obs, [torch.Generator().manual_seed(0)]).actions
              for d in ("cpu", "cuda")]
    assert chunks[1].device.type == "cpu"  # chunks come back on the CPU
    assert torch.allclose(chunks[0], chunks[1], atol=1e-3)
