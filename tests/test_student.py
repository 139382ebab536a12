"""The few-step student (scdp.training.distill): distilled from the base with the predictors' films,
planned by dp_student and scdp_student, exported to ONNX like the base."""

import json
import shutil

import numpy as np
import pytest
import torch

from helpers.tiny import TINY
from scdp.cli import main
from scdp.config import PlanningOptions
from scdp.errors import ScdpError
from scdp.evaluation.rollout import rollout
from scdp.keys import STUDENT_PART
from scdp.policies.export import export_checkpoints
from scdp.policies.loaders import load_method
from scdp.tasks import NAVIGATION
from scdp.training import parts
from scdp.training.distill import Distillation, chunk_loss, deterministic_chunk, draw_films
from scdp.training.recipe import model_parts, part_recipe

# seconds: 4 epochs over the windows of 3 demos, a 4-step teacher
STUDENT = TINY.with_overrides(["data.base_demos=3", "student.train.epochs=4", "student.train.batch_size=32",
                               "student.teacher_steps=4", "student.train.lr=3e-3"])
ONNX_PATH_TOLERANCE = 1e-4  # metres: a whole rollout through ONNX Runtime against torch (float32 both; 8e-7 here)


@pytest.fixture(scope="module")
def student_ckpt(tiny_ckpt, small_datasets, tmp_path_factory):
    root = tmp_path_factory.mktemp("student") / "checkpoints"
    shutil.copytree(tiny_ckpt, root)
    parts.train_part(NAVIGATION, STUDENT, STUDENT_PART, root / STUDENT_PART, dataset=small_datasets["navigation"],
                     base_dir=root / "base", encoder_dir=root / "encoder", progress=False)
    return root


def _distillation(root) -> tuple[Distillation, Distillation]:
    """The trained student's distillation, and the same with the untrained start (the base's weights)."""
    planning = PlanningOptions(sampler="ddim", steps=STUDENT.student.teacher_steps)
    teacher = load_method("scdp_blend", root, NAVIGATION, planning)
    student = load_method("dp_student", root, NAVIGATION)
    start = load_method("dp", root, NAVIGATION, PlanningOptions(sampler="ddim", steps=STUDENT.student.steps))
    return Distillation(teacher, student, 0.75, 0.0), Distillation(teacher, start, 0.75, 0.0)


def test_the_student_is_closer_to_its_teacher_than_the_base_at_the_same_steps(student_ckpt, small_datasets):
    from scdp.data.windows import WindowData

    trained, start = _distillation(student_ckpt)
    data = WindowData(small_datasets["navigation"], trained.student.n_obs_steps, trained.student.config.horizon, NAVIGATION)
    batch = data.get(torch.arange(min(64, len(data))))
    gaps = [d.gap(batch, torch.Generator().manual_seed(7)) for d in (trained, start)]
    assert gaps[0] < 0.95 * gaps[1], gaps  # distillation moved the 2-step chunks towards the teacher's (0.90 here)


def test_the_student_plans_in_its_own_steps_and_keeps_the_films(student_ckpt):
    meta = json.loads((student_ckpt / STUDENT_PART / "config.json").read_text())
    assert (meta["config"]["sampler"], meta["config"]["num_inference_steps"]) == ("ddim", STUDENT.student.steps)
    assert meta["distilled"] == {"teacher_sampler": "ddim", "teacher_steps": STUDENT.student.teacher_steps, "styled": 0.75,
                                 "step_weight": STUDENT.student.step_weight}
    for profile in ("trained", "realtime"):  # the realtime profile's DDPM-8 is the base's, not the student's
        planner = load_method("scdp_student", student_ckpt, NAVIGATION, PlanningOptions(profile=profile))
        assert (planner.base.config.sampler, planner.base.config.num_inference_steps, planner.base.warm_skip) == ("ddim", 2, 0)
    # the films reach the student's network: a legible chunk differs from a plain one
    trained, _ = _distillation(student_ckpt)
    torch.manual_seed(0)
    config = trained.student.config
    z, cond = torch.randn(4, config.horizon, config.state_dim), torch.randn(4, config.global_cond_dim)
    film = trained.teacher.film(torch.randn(4, 2, 2), torch.zeros(4, dtype=torch.long), np.ones(4), torch.randn(4, 2))
    styled = deterministic_chunk(trained.student, z, cond, film, 0)
    plain = deterministic_chunk(trained.student, z, cond, None, 0)
    assert (styled - plain).abs().max() > 1e-3


def test_the_student_plans_the_same_path_as_its_onnx_export(student_ckpt, tmp_path):
    root = tmp_path / "checkpoints"
    shutil.copytree(student_ckpt, root)
    assert list(export_checkpoints(root, NAVIGATION, only=(STUDENT_PART,))) == [STUDENT_PART]  # a student trained last
    assert not (root / "base" / "model.onnx").exists()
    paths = {}
    for runtime in ("torch", "onnx"):
        planner = load_method("scdp_student", root, NAVIGATION, PlanningOptions(runtime=runtime))
        assert type(planner.base.unet).__name__ == ("OnnxDenoiser" if runtime == "onnx" else "ConditionalUnet1D")
        (run,) = rollout(NAVIGATION, planner, [(NAVIGATION.layouts[0], 1)], seeds=[5])
        paths[runtime] = np.asarray(run.path)
    assert paths["torch"].shape == paths["onnx"].shape
    gap = np.abs(paths["torch"] - paths["onnx"]).max()
    assert gap < ONNX_PATH_TOLERANCE


def test_a_model_set_that_evaluates_a_student_trains_it_after_the_predictors():
    preset = TINY.with_overrides(["evaluation.methods=[\"dp\", \"ld\", \"scdp\", \"scdp_student\"]"])
    assert model_parts(preset) == ("base", "style_legible", "style_efficient", STUDENT_PART, "ld")
    assert STUDENT_PART not in model_parts(TINY)


def test_the_step_term_costs_a_jump_more_than_an_even_drift_of_the_same_point_error():
    H = 16
    target = torch.zeros(1, H, 1)
    drift = torch.linspace(0.0, 1.0, H).reshape(1, H, 1)  # an offset growing evenly along the chunk
    jump = torch.zeros(1, H, 1)
    jump[0, H // 2] = drift.pow(2).sum().sqrt()  # one point out of line, the same squared point error in all
    assert chunk_loss(jump, target, 0.0) == pytest.approx(float(chunk_loss(drift, target, 0.0)))
    # with w = H²: a jump's step term is 2H³/(H - 1) ≈ 546 × its point error, a drift's 6H²/((H - 1)(2H - 1)) ≈ 3.3 ×
    assert chunk_loss(jump, target, 256.0) > 100 * chunk_loss(drift, target, 256.0)


def test_a_student_without_the_step_term_keeps_the_recipe_it_had_before_the_term_existed():
    assert "step_weight" not in part_recipe(TINY, STUDENT_PART)["student"]  # the committed students stay current
    weighted = TINY.with_overrides(["student.step_weight=256"])
    assert part_recipe(weighted, STUDENT_PART)["student"]["step_weight"] == 256.0


def test_film_codes_follow_the_styled_share():
    codes = draw_films(4000, 0.75, torch.Generator().manual_seed(0))
    share = [(codes == c).float().mean().item() for c in range(3)]
    assert abs(share[0] - 0.25) < 0.03 and abs(share[1] - 0.375) < 0.03 and abs(share[2] - 0.375) < 0.03


def test_a_student_with_as_many_steps_as_its_teacher_is_refused():
    with pytest.raises(ScdpError, match="steps"):
        TINY.with_overrides(["student.steps=8", "student.teacher_steps=8"])


def test_export_refuses_a_part_that_is_not_there_or_not_a_denoiser(tiny_ckpt, capsys):
    assert main(["export", "--task", "navigation", str(tiny_ckpt), "--parts", "encoder"]) == 2
    assert capsys.readouterr().err.strip() == ("scdp: error: --parts: encoder: not a diffusion part (choose from base, ld, "
                                               "student)")
    assert main(["export", "--task", "navigation", str(tiny_ckpt), "--parts", "student"]) == 2
    assert capsys.readouterr().err.strip() == f"scdp: error: --parts: {tiny_ckpt} holds no student checkpoint"


def test_a_service_offers_the_student_where_the_folder_holds_one(tiny_ckpt, student_ckpt):
    from scdp.serve.app import served_methods

    assert not {"dp_student", "scdp_student"} & set(served_methods(tiny_ckpt))
    assert {"dp", "scdp", "dp_student", "scdp_student"} <= set(served_methods(student_ckpt))
