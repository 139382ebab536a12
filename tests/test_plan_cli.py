"""`scdp plan` and `scdp train` end to end on tiny checkpoints, and their refusals."""

import json
import shutil

import pytest

from scdp.cli import main
from scdp.policies.loaders import load_ld
from scdp.tasks import NAVIGATION


@pytest.fixture(scope="module")
def ckpt(tmp_path_factory, small_datasets):
    root = tmp_path_factory.mktemp("plan")
    data = root / "demos.zarr"
    small_datasets["navigation"].save(data)
    for part, extra in [("base", []), ("ld", []), ("encoder", []),
                        ("style", ["--style", "legible"]), ("style", ["--style", "efficient"])]:
        out = root / "ck" / (f"style_{extra[1]}" if extra else part)
        args = ["train", part, "--task", "navigation", "--preset", "tiny", "--out", str(out), *extra]
        if part != "encoder":
            args += ["--data", str(data)]
        assert main(args) == 0
    return root / "ck"


@pytest.mark.parametrize("method", ["dp", "ld", "scdp"])
def test_plan_each_method(ckpt, tmp_path, method, capsys):
    out = tmp_path / f"{method}.json"
    code = main(["plan", "--task", "navigation", "--checkpoints", str(ckpt), "--goals", "2.0,0.2", "2.0,-0.2",
                 "--target", "1", "--method", method, "--seed", "3", "--out", str(out)])
    assert code == 0
    traj = json.loads(out.read_text())
    assert traj["method"] == method and traj["target"] == 1
    assert len(traj["path"]) == len(traj["states"]) == len(traj["actions"]) + 1
    assert len(traj["styles"]) >= 1 and "planning_seconds" in traj
    for key in ("d_hat", "e_hat", "transparency", "legibility", "detachment", "efficiency"):
        assert isinstance(traj["metrics"][key], float)
    if method == "scdp":
        assert set(traj["styles"]) <= {"legible", "efficient"}
    else:
        assert set(traj["styles"]) == {"none"}


def test_plan_fixed_style(ckpt, tmp_path):
    out = tmp_path / "s.json"
    assert main(["plan", "--task", "navigation", "--checkpoints", str(ckpt), "--goals", "2.0,0.2", "2.0,-0.2",
                 "--method", "scdp", "--style", "efficient", "--out", str(out)]) == 0
    assert set(json.loads(out.read_text())["styles"]) == {"efficient"}


def test_plan_takes_another_sampler_and_step_count_and_refuses_bad_ones(ckpt, tmp_path, capsys):
    base = ["plan", "--task", "navigation", "--checkpoints", str(ckpt), "--goals", "2.0,0.2", "2.0,-0.2", "--method", "dp",
            "--seed", "5"]
    paths = {}
    for name, extra in [("saved", []), ("ddpm3", ["--sampler", "ddpm", "--steps", "3"]),
                        ("ddpm3_again", ["--sampler", "ddpm", "--steps", "3"])]:
        out = tmp_path / f"{name}.json"
        assert main([*base, "--out", str(out), *extra]) == 0
        paths[name] = json.loads(out.read_text())["path"]
    assert paths["ddpm3"] == paths["ddpm3_again"]  # seeded
    assert paths["ddpm3"] != paths["saved"]  # the tiny preset saves ddim at 4 steps: another sampler plans otherwise
    for extra, says in [(["--steps", "0"], "--steps: must be 1..100"), (["--steps", "101"], "--steps: must be 1..100"),
                        (["--sampler", "euler"], "--sampler: invalid choice")]:
        assert main([*base, "--out", str(tmp_path / "bad.json"), *extra]) == 2
        assert says in capsys.readouterr().err
    assert not (tmp_path / "bad.json").exists()


def test_evaluate_on_a_layout_with_a_shared_encoder(ckpt, tmp_path, capsys):
    """A per-layout model set keeps no encoder of its own: --encoder points at the task's."""
    sets = tmp_path / "layout_2"
    shutil.copytree(ckpt, sets)
    shutil.move(sets / "encoder", tmp_path / "encoder")
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--task", "navigation", "--checkpoints", str(sets), "--methods", "dp", "scdp:legible",
            "--layout", "2", "--scenes", "3", "--out", str(out)]
    assert main(argv) == 2 and "encoder" in capsys.readouterr().err  # not found in the model set
    assert main(argv + ["--encoder", str(tmp_path / "encoder")]) == 0
    result = json.loads(out.read_text())
    assert set(result["runs"]) == {"layout_2"} and set(result["runs"]["layout_2"]) == {"dp", "scdp:legible"}
    assert all(run["n"] == 3 for run in result["runs"]["layout_2"].values())
    assert main(argv[:-2] + ["--layout", "7"]) == 2 and "--layout" in capsys.readouterr().err


def test_evaluate_splits_scene_sets_and_pairs_against_the_baseline(ckpt, tmp_path, capsys):
    """The re-check a reader runs on new scenes: ambiguous and clear sets, differences against DP, under both
    normalisations (the demos beside the checkpoints give the training data's range)."""
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--task", "navigation", "--checkpoints", str(ckpt), "--methods", "dp", "scdp_legible",
            "--scenes", "3", "--seed", "9", "--out", str(out)]
    assert main(argv) == 0
    result = json.loads(out.read_text())
    assert set(result["runs"]) == {"ambiguous", "non_ambiguous"}
    assert {r["normalisation"] for r in result["differences"]} == {"scene", "dataset"}
    assert result["normalisation_range"]["demos"] == 12  # the 12 demos beside the checkpoints
    for scene_set, runs in result["runs"].items():
        rows = {r["metric"]: r for r in result["differences"] if r["scene_set"] == scene_set and r["normalisation"] == "scene"}
        other = {r["metric"]: r for r in result["differences"] if r["scene_set"] == scene_set and r["normalisation"] == "dataset"}
        assert other["success"]["mean"] == rows["success"]["mean"]  # success does not depend on the normalisation
        assert other["d_hat"]["mean"] != rows["d_hat"]["mean"]
        assert set(rows) == {"transparency_fa", "transparency", "d_hat", "e_hat", "success"}
        for metric in ("transparency", "d_hat"):  # paired mean = difference of the two means on the same scenes
            expected = runs["scdp_legible"][metric]["mean"] - runs["dp"][metric]["mean"]
            assert abs(rows[metric]["mean"] - expected) < 1e-9 and rows[metric]["lo"] <= rows[metric]["mean"] <= rows[metric]["hi"]
            assert rows[metric]["a"] == "scdp_legible" and rows[metric]["b"] == "dp" and rows[metric]["n"] == 3
    printed = capsys.readouterr().out
    assert "scdp_legible − dp" in printed and "D̂ and Ê over the training data (the paper's wording)" in printed
    assert main(argv[:-2] + ["--demos", str(tmp_path / "none.zarr"), "--out", str(tmp_path / "y.json")]) == 2
    assert f"scdp: error: --demos: {tmp_path / 'none.zarr'} does not exist" in capsys.readouterr().err
    assert main(argv[:-2] + ["--baseline", "ld", "--out", str(tmp_path / "x.json")]) == 2
    assert "--baseline" in capsys.readouterr().err


def test_dry_run_prints_json_last(capsys):
    assert main(["train", "base", "--task", "block_reach", "--preset", "paper", "--dry-run"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    info = json.loads(last)
    assert info["part"] == "base" and 65e6 <= info["parameters"] <= 70e6


def _plan(ckpt_dir, tmp_path, *extra, task="navigation", goals=("2.0,0.2", "2.0,-0.2"), method="dp"):
    return main(["plan", "--task", task, "--checkpoints", str(ckpt_dir), "--goals", *goals, "--method", method,
                 "--out", str(tmp_path / "o.json"), *extra])


def _refused(capsys, field, code):
    """The call exited 2 with one ``scdp: error: <field>`` line."""
    err = capsys.readouterr().err.strip()
    assert code == 2 and err.startswith(f"scdp: error: {field}") and "\n" not in err, err


def test_plan_refusals(ckpt, tmp_path, capsys):
    _refused(capsys, "task:", _plan(ckpt, tmp_path, task="block_reach", goals=("0.5,0.1", "0.5,-0.1")))
    _refused(capsys, "goals:", _plan(ckpt, tmp_path, goals=("2.0,nan", "2.0,-0.2")))
    _refused(capsys, "goals:", _plan(ckpt, tmp_path, goals=("9.0,0.2", "2.0,-0.2")))
    _refused(capsys, "--goals:", _plan(ckpt, tmp_path, goals=("2.0,0.2", "2.0,-0.2", "1.0,1.0"), method="scdp"))
    partial = tmp_path / "partial"
    shutil.copytree(ckpt, partial)
    shutil.rmtree(partial / "encoder")
    _refused(capsys, "checkpoints/encoder:", _plan(partial, tmp_path, method="scdp"))
    corrupt = tmp_path / "corrupt"
    shutil.copytree(ckpt, corrupt)
    (corrupt / "base" / "model.safetensors").write_bytes(b"nonsense")
    _refused(capsys, "checkpoints/base:", _plan(corrupt, tmp_path))
    assert not (tmp_path / "o.json").exists()


def test_set_overrides_are_applied_and_recorded(small_datasets, tmp_path, capsys):
    out = tmp_path / "encoder"
    assert main(["train", "encoder", "--task", "navigation", "--preset", "tiny", "--out", str(out),
                 "--set", "encoder.model.context_dim=12", "--set", "encoder.model.hidden=[24]"]) == 0
    meta = json.loads((out / "config.json").read_text())
    assert meta["config"]["context_dim"] == 12 and meta["config"]["hidden"] == [24]
    assert meta["overrides"] == ["encoder.model.context_dim=12", "encoder.model.hidden=[24]"]
    capsys.readouterr()
    _refused(capsys, "--set:", main(["train", "encoder", "--task", "navigation", "--preset", "tiny", "--out",
                                     str(tmp_path / "e2"), "--set", "encoder.model.context_dim=-1"]))
    assert not (tmp_path / "e2").exists()


def test_ld_checkpoint_carries_its_guidance(small_datasets, tmp_path):
    data = tmp_path / "demos.zarr"
    small_datasets["navigation"].save(data)
    out = tmp_path / "ld"
    assert main(["train", "ld", "--task", "navigation", "--preset", "tiny", "--data", str(data), "--out", str(out),
                 "--set", "ld.guidance.w0=2.0", "--set", "ld.guidance.p_uncond=0.2", "--set", "ld.init=scratch"]) == 0
    meta = json.loads((out / "config.json").read_text())
    assert meta["guidance"]["w0"] == 2.0 and meta["config"]["p_uncond"] == 0.2
    ld = load_ld(out, NAVIGATION)
    assert ld.guidance.w0 == 2.0 and ld.w == 2.0 and ld.policy.config.p_uncond == 0.2


def test_train_refuses_existing_checkpoint_and_wrong_task(ckpt, tmp_path, small_datasets, capsys):
    assert main(["train", "encoder", "--task", "navigation", "--preset", "tiny", "--out", str(ckpt / "encoder")]) == 2
    assert "already holds a checkpoint" in capsys.readouterr().err
    data = tmp_path / "br.zarr"
    small_datasets["block_reach"].save(data)
    assert main(["train", "base", "--task", "navigation", "--preset", "tiny", "--data", str(data), "--out", str(tmp_path / "b")]) == 2
    assert "task" in capsys.readouterr().err
