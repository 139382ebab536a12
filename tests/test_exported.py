"""The exported denoiser (scdp.policies.exported): scdp export, parity with torch, --runtime onnx
for every planner on both tasks, and the refusals."""

import json
import shutil

import numpy as np
import pytest
from safetensors.numpy import load_file, save_file

from scdp.cli import main
from scdp.config import PlannerSpec, PlanningOptions
from scdp.errors import ScdpError
from scdp.evaluation.records import scene_bounds, score_rollout
from scdp.evaluation.rollout import rollout
from scdp.models.film import Film
from scdp.policies import exported
from scdp.policies.checkpoint import save_part
from scdp.policies.loaders import load_diffusion, load_method
from scdp.tasks import get_task

PLANNERS = ("dp", "ld", "ld_paper", "scdp", "scdp_blend", "scdp_legible", "scdp_efficient", "scdp_paper")
SCENES = {"navigation": [([[2.0, 0.4], [2.0, -0.4]], 0)], "block_reach": [([[0.5, 0.1, 0.1], [0.5, -0.1, 0.1]], 1)]}


@pytest.fixture(scope="module")
def exported_run(exported_tiny):
    return exported_tiny


def test_export_writes_a_checked_graph_beside_each_diffusion_checkpoint(exported_run):
    for task in SCENES:
        for part in ("base", "ld"):
            meta = json.loads((exported_run / task / part / "onnx.json").read_text())
            assert (exported_run / task / part / "model.onnx").stat().st_size > 0
            assert meta["part"] == part and meta["parity"]["max_abs_error"] <= 1e-4
            assert meta["sampler"] and meta["normalizer"] and meta["inputs"] == ["x", "k", "cond", "gamma", "beta"]


@pytest.mark.parametrize("task", list(SCENES))
def test_every_planner_plans_the_same_with_onnx_as_with_torch(exported_run, task):
    task_obj = get_task(task)
    for name in PLANNERS:
        runs = {}
        for runtime in ("torch", "onnx"):
            planner = load_method(name, exported_run / task, task_obj, PlanningOptions(runtime=runtime))
            runs[runtime] = rollout(task_obj, planner, SCENES[task], seed=7)
        # the two runtimes round differently in float32 (about 1e-6 per call, onnx.json); over 20 calls a
        # chunk and up to 50 chunks of an untrained tiny net that drift stays below 2e-4 here
        for a, b in zip(runs["torch"], runs["onnx"]):
            assert a.styles == b.styles and a.success == b.success, name
            assert np.abs(np.asarray(a.path) - np.asarray(b.path)).max() < 1e-3, name
            ma, mb = (score_rollout(task_obj, r, method=name, scene_set="x", bounds=scene_bounds(task_obj, r.goals, r.target)).metrics
                      for r in (a, b))
            assert all(abs(ma[k] - mb[k]) < 1e-3 for k in ma), name


def test_the_graph_is_written_in_the_forms_onnx_runtime_runs_fast(exported_run):
    import onnx

    graph = onnx.load(str(exported_run / "navigation" / "base" / "model.onnx")).graph
    ops = {n.op_type for n in graph.node}
    assert "Softplus" not in ops and "Exp" in ops  # Mish in its one-exponential form
    kernels = [list(a.ints) for n in graph.node if n.op_type == "Conv" for a in n.attribute if a.name == "kernel_shape"]
    assert kernels and all(len(k) == 2 and k[0] == 1 for k in kernels)  # every Conv1d as a 2-D conv of height 1


def test_the_exported_mish_is_mish_over_the_whole_float_range(tmp_path):
    import torch

    from scdp.models.mish import Mish

    x = torch.cat([torch.linspace(-100, 100, 2001), torch.tensor([-1e30, 1e30, 0.0])])[None]
    torch.onnx.export(Mish(), (x,), str(tmp_path / "mish.onnx"), input_names=["x"], output_names=["y"], dynamo=False)
    got = exported.session(tmp_path / "mish.onnx", threads=1).run(["y"], {"x": x.numpy()})[0]
    want = torch.nn.functional.mish(x.double()).numpy()
    assert np.isfinite(got).all()
    assert np.abs(got - want).max() <= 1e-5 * np.maximum(1, np.abs(want)).max()


def test_the_onnx_denoiser_is_used_and_takes_a_style_film(exported_run):
    task = get_task("navigation")
    policy = load_diffusion(exported_run / "navigation" / "base", task, planning=PlanningOptions(runtime="onnx"))
    assert isinstance(policy.unet, exported.OnnxDenoiser)
    torch_net = load_diffusion(exported_run / "navigation" / "base", task).unet
    import torch

    B, cfg = 3, policy.config
    x, k, cond = torch.randn(B, cfg.horizon, cfg.state_dim), torch.tensor([0, 5, 9]), torch.randn(B, cfg.global_cond_dim)
    for placement in ("bottleneck", "all"):
        width = torch_net.film_width(placement)
        film = Film(1 + 0.3 * torch.randn(B, width), 0.3 * torch.randn(B, width), placement)
        with torch.no_grad():
            want = torch_net(x, k, cond, film)
        got = policy.unet(x, k, cond, film)
        assert (got - want).abs().max() < 1e-4
        assert (got - policy.unet(x, k, cond)).abs().max() > 1e-3  # the film changes the output


def test_a_graph_that_fails_parity_is_refused_and_nothing_is_written(tiny_reproduction, tmp_path):
    folder = tmp_path / "base"
    shutil.copytree(tiny_reproduction / "navigation" / "checkpoints" / "base", folder)
    policy = load_diffusion(folder, get_task("navigation"))
    cfg = policy.config
    with pytest.raises(ScdpError) as err:
        exported.export_denoiser(policy.unet, folder, horizon=cfg.horizon, state_dim=cfg.state_dim,
                                 cond_dim=cfg.global_cond_dim, steps=cfg.num_train_timesteps, tolerance=0.0)
    assert "fails parity with torch" in err.value.message and "eps at batch" in err.value.message
    assert not (folder / "model.onnx").exists() and not (folder / "onnx.json").exists()
    assert not any(p.name.endswith(".tmp") for p in folder.iterdir())


def test_the_cli_refusals(exported_run, tiny_reproduction, tmp_path, capsys):
    folder = str(exported_run / "navigation")
    assert main(["export", "--task", "navigation", folder]) == 2  # exists: --force needed
    assert capsys.readouterr().err.startswith("scdp: error: checkpoints: ")
    plan = ["plan", "--task", "navigation", "--goals", "2,0.4", "2,-0.4", "--method", "dp", "--out", str(tmp_path / "p.json")]
    assert main([*plan, "--checkpoints", str(tiny_reproduction / "navigation" / "checkpoints"), "--runtime", "onnx"]) == 2
    assert "run scdp export" in capsys.readouterr().err
    assert main([*plan, "--checkpoints", folder, "--runtime", "onnx", "--device", "cuda"]) == 2
    assert capsys.readouterr().err.startswith("scdp: error: --runtime: onnx runs on the CPU")
    assert main([*plan, "--checkpoints", folder, "--runtime", "onnx"]) == 0
    assert not (tmp_path / "q.json").exists()


def _exported_copy(exported_run, tmp_path):
    folder = tmp_path / "navigation"
    shutil.copytree(exported_run / "navigation", folder)
    return folder


def _plan(folder, tmp_path, capsys) -> tuple[int, str]:
    capsys.readouterr()
    code = main(["plan", "--task", "navigation", "--goals", "2,0.4", "2,-0.4", "--method", "dp", "--checkpoints", str(folder),
                 "--runtime", "onnx", "--out", str(tmp_path / "plan.json")])
    return code, capsys.readouterr().err


def test_a_graph_exported_from_other_weights_is_refused_in_one_line(exported_run, tmp_path, capsys):
    folder = _exported_copy(exported_run, tmp_path)
    base = folder / "base"
    tensors = load_file(base / "model.safetensors")
    name = sorted(tensors)[0]
    save_file({**tensors, name: tensors[name] + np.float32(1e-2)}, base / "model.safetensors")
    meta = json.loads((base / "config.json").read_text())  # as a retrain into the folder leaves it, hash updated
    (base / "config.json").write_text(json.dumps({**meta, "weights_sha256": exported.file_sha256(base / "model.safetensors")}))
    code, err = _plan(folder, tmp_path, capsys)
    assert code == 2 and err.count("\n") == 1 and "exported from other weights" in err and "--force" in err
    assert not (tmp_path / "plan.json").exists()
    assert main(["export", "--task", "navigation", str(folder), "--force"]) == 0  # the fix it names works
    assert _plan(folder, tmp_path, capsys)[0] == 0


def test_a_damaged_graph_is_refused_in_one_line(exported_run, tmp_path, capsys):
    folder = _exported_copy(exported_run, tmp_path)
    graph = folder / "base" / "model.onnx"
    graph.write_bytes(graph.read_bytes()[: graph.stat().st_size // 2])
    code, err = _plan(folder, tmp_path, capsys)
    assert code == 2 and err.startswith("scdp: error: --runtime: ") and err.count("\n") == 1 and "damaged" in err


def test_an_unloadable_graph_with_a_matching_record_is_refused_in_one_line(exported_run, tmp_path, capsys):
    folder = _exported_copy(exported_run, tmp_path)
    graph, record = folder / "base" / "model.onnx", folder / "base" / "onnx.json"
    graph.write_bytes(b"not a protobuf")
    record.write_text(json.dumps({**json.loads(record.read_text()), "onnx_sha256": exported.file_sha256(graph)}))
    code, err = _plan(folder, tmp_path, capsys)
    assert code == 2 and err.count("\n") == 1 and "cannot be loaded" in err


def test_saving_a_part_removes_the_graph_exported_from_its_earlier_weights(exported_run, tmp_path):
    folder = _exported_copy(exported_run, tmp_path) / "base"
    policy = load_diffusion(folder, get_task("navigation"))
    meta = json.loads((folder / "config.json").read_text())
    save_part(folder, policy, part="base", task="navigation", preset=meta["preset"], config=policy.config,
              normalizer=policy.normalizer)
    assert not (folder / "model.onnx").exists() and not (folder / "onnx.json").exists()


def test_runtime_auto_runs_the_graph_for_small_batches_and_torch_for_large(exported_run, monkeypatch):
    import torch

    task = get_task("navigation")
    policy = load_diffusion(exported_run / "navigation" / "base", task, planning=PlanningOptions(runtime="auto"))
    assert isinstance(policy.unet, exported.AutoDenoiser)
    graph_calls = []
    real = policy.unet.onnx.session.run
    monkeypatch.setattr(policy.unet.onnx.session, "run", lambda *a, **kw: graph_calls.append(1) or real(*a, **kw))
    cfg = policy.config
    for batch, through_graph in ((1, True), (exported.AUTO_BATCH - 1, True), (exported.AUTO_BATCH, False)):
        before = len(graph_calls)
        with torch.no_grad():
            policy.unet(torch.randn(batch, cfg.horizon, cfg.state_dim), torch.zeros(batch, dtype=torch.long),
                        torch.randn(batch, cfg.global_cond_dim))
        assert (len(graph_calls) > before) == through_graph, batch
    assert policy.device == torch.device("cpu")


def test_a_service_with_runtime_onnx_serves_what_has_a_graph_and_names_the_rest(exported_run, tmp_path, capsys):
    """The committed runs export only the base's graph: --runtime onnx runs it there, and LD, whose
    denoiser has none, runs in torch, named at start-up with the command that exports it."""
    from fastapi.testclient import TestClient

    from scdp.serve.app import PlanningService, create_app

    folder = _exported_copy(exported_run, tmp_path)
    for name in ("onnx.json", "model.onnx"):
        (folder / "ld" / name).unlink()
    service = PlanningService(folder, "navigation", methods=["dp", "ld"], planning=PlanningOptions(runtime="onnx"))
    assert {p: v["runtime"] for p, v in service.parts.items()} == {"base": "onnx", "ld": "torch"}
    assert len(service.notes) == 1 and "checkpoints/ld has no exported denoiser" in service.notes[0]
    assert "so ld run it in torch" in service.notes[0] and "scdp export --task navigation" in service.notes[0]
    assert isinstance(service.planner(PlannerSpec.of("dp")).unet, exported.OnnxDenoiser)
    with TestClient(create_app(service)) as client:  # what a client is told runs where
        info = client.get("/v1/info").json()
    assert info["planning"]["ld"]["runtime"] == "torch" and info["planning"]["dp"]["runtime"] == "onnx"
