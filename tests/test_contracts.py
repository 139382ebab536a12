"""The written contracts: style arbitration, the action and goal-offset conventions, the planner protocol."""

import copy

import numpy as np
import pytest
import torch

from scdp.data.windows import WindowData
from scdp.evaluation.rollout import rollout
from scdp.models.scene_encoder import scene_frame
from scdp.models.style_predictor import predictor_input
from scdp.policies.base import Observation, Planner
from scdp.policies.legibility_diffuser import LegibilityDiffuser
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.presets import PRESETS
from scdp.tasks import NAVIGATION
from scdp.training import parts

TINY = PRESETS["tiny"]


@pytest.fixture(scope="module")
def untrained_scdp():
    base = parts.build_diffusion(NAVIGATION, TINY)
    encoder = parts.build_encoder(NAVIGATION, TINY)
    predictors = {s: parts.build_style(TINY, base, encoder) for s in ("legible", "efficient")}
    return StyleConditionedPolicy(base, encoder, predictors, NAVIGATION, style="auto")


def _styles(policy, positions, goals, target):
    positions = np.asarray(positions, dtype=np.float64)
    n = len(positions)
    return policy.choose_styles(positions, np.repeat(np.asarray(goals, dtype=np.float64)[None], n, 0), np.full(n, target))


def test_arbitration_legible_in_ambiguous_scenes_efficient_in_clear_ones(untrained_scdp):
    start = NAVIGATION.start_point[None]
    assert _styles(untrained_scdp, start, NAVIGATION.layouts[0], 0) == ["legible"]  # goals 0.4 m apart, side by side
    assert _styles(untrained_scdp, start, NAVIGATION.layouts[4], 0) == ["efficient"]  # goals 1.4 m apart
    assert _styles(untrained_scdp, start, NAVIGATION.layouts[4], 1) == ["efficient"]


def test_arbitration_switches_once_the_distractor_is_passed(untrained_scdp):
    goals = np.array([[3.0, 0.0], [1.5, 0.3]])  # the distractor halfway along the way to g*
    xs = np.linspace(0.0, 2.8, 29)
    styles = _styles(untrained_scdp, np.column_stack([xs, np.zeros_like(xs)]), goals, 0)
    switch = styles.index("efficient")
    assert switch > 0 and styles[:switch] == ["legible"] * switch and styles[switch:] == ["efficient"] * (len(xs) - switch)
    assert xs[switch] > 1.0  # it stays legible until the robot is close to passing the distractor


def test_fixed_styles_ignore_the_scene(untrained_scdp):
    fixed = StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, untrained_scdp.predictors, NAVIGATION,
                                   style="legible")
    assert _styles(fixed, NAVIGATION.start_point[None], NAVIGATION.layouts[4], 0) == ["legible"]


def _policy_and_batch(dataset, switch: str, on: bool, stride: int):
    """A tiny base with one preprocessing switch set, fitted on ``dataset``, and a batch of its windows."""
    preset = TINY.with_overrides([f"base.model.{switch}={str(on).lower()}"])
    model = preset.base.model
    windows = WindowData(dataset, model.n_obs_steps, model.horizon, NAVIGATION)
    return model, parts.build_diffusion(NAVIGATION, preset, windows), windows.get(torch.arange(0, len(windows), stride))


@pytest.mark.parametrize("relative", [True, False])
def test_action_chunks_round_trip(small_datasets, relative):
    """What the loss learns (scaled, maybe relative) is turned back into the demo's absolute next states."""
    model, policy, batch = _policy_and_batch(small_datasets["navigation"], "relative_actions", relative, 7)
    chunk = batch.action - batch.obs_state[:, -1:] if relative else batch.action
    scaled = policy.normalizer.action.normalize(chunk)
    assert scaled.abs().max() <= 1.0 + 1e-5  # the normaliser was fitted on exactly these chunks
    executed = policy.actions_to_execute(scaled, batch.obs_state)
    start = model.n_obs_steps - 1
    assert torch.allclose(executed, batch.action[:, start:start + model.n_action_steps], atol=1e-5)


@pytest.mark.parametrize("offset", [True, False])
def test_goal_offset_round_trip(small_datasets, offset):
    """The condition holds g* - p(s) when asked; training (stored positions) and planning (kinematics) agree."""
    model, policy, batch = _policy_and_batch(small_datasets["navigation"], "goal_offset", offset, 5)
    cond = policy.observe(batch.obs_state, batch.goal)
    S, G, O = 3, 2, model.n_obs_steps  # noqa: E741 (O: n_obs_steps, as in the shape comments)
    assert cond.shape == (len(batch.goal), O * (S + G * (2 if offset else 1))) and cond.shape[1] == policy.config.global_cond_dim
    assert torch.allclose(cond, policy.observe(batch.obs_state, batch.goal, position=batch.obs_position), atol=1e-6)
    if offset:
        per_step = cond.reshape(len(batch.goal), O, -1)
        recovered = policy.normalizer.offset.unnormalize(per_step[..., S + G:])
        assert torch.allclose(recovered, batch.goal[:, None] - batch.obs_position, atol=1e-5)


def test_every_planner_implements_the_protocol(untrained_scdp):
    base = untrained_scdp.base
    for planner in (base, untrained_scdp, LegibilityDiffuser(base)):
        assert isinstance(planner, Planner) and planner.n_obs_steps == TINY.base.model.n_obs_steps
        obs = Observation(state_hist=torch.zeros(2, planner.n_obs_steps, 3), position=torch.zeros(2, 2),
                          goals=torch.tensor(NAVIGATION.layouts[:2], dtype=torch.float32), target=torch.tensor([0, 1]))
        planner.reset()
        chunk = planner.act(obs, torch.Generator().manual_seed(0))
        assert chunk.actions.shape == (2, TINY.base.model.n_action_steps, 3) and len(chunk.styles) == 2


def test_a_scenes_noise_does_not_depend_on_its_batch(untrained_scdp):
    """Per-scene generators: scene B planned beside A, or alone, gets the same path."""
    a, b = (NAVIGATION.layouts[0], 0), (NAVIGATION.layouts[4], 1)
    together = rollout(NAVIGATION, untrained_scdp.base, [a, b], seeds=[11, 22])
    alone = rollout(NAVIGATION, untrained_scdp.base, [b], seeds=[22])
    other = rollout(NAVIGATION, untrained_scdp.base, [b], seeds=[23])
    first = slice(0, TINY.base.model.n_action_steps + 1)  # the first chunk: later ones amplify float round-off
    assert np.allclose(np.asarray(together[1].path)[first], np.asarray(alone[0].path)[first], atol=1e-6)
    assert np.abs(np.asarray(alone[0].path)[first] - np.asarray(other[0].path)[first]).max() > 1e-3


def test_blend_weights_are_smooth_and_agree_with_the_ellipse_at_the_extremes(untrained_scdp):
    blend = StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, untrained_scdp.predictors, NAVIGATION,
                                   style="blend")
    goals = np.array([[3.0, 0.0], [1.5, 0.3]])
    xs = np.linspace(0.0, 2.8, 29)
    positions = np.column_stack([xs, np.zeros_like(xs)])
    weights = blend.legible_weights(positions, np.repeat(goals[None], len(xs), 0), np.zeros(len(xs), dtype=int))
    hard = _styles(untrained_scdp, positions, goals, 0)
    assert np.all((weights > 0) & (weights < 1)) and len(set(np.round(weights, 6))) > 10  # smooth, not a switch
    assert [w > 0.5 for w in weights] == [s == "legible" for s in hard]  # the same side of the boundary
    film = blend.film(torch.tensor(goals[None], dtype=torch.float32).repeat(2, 1, 1), torch.tensor([0, 0]), np.array([1.0, 0.0]),
                      torch.zeros(2, 2))
    predictor = untrained_scdp.predictors["legible"]  # on its own input (context, and the scene frame where it reads one)
    legible = predictor(predictor_input(predictor.config, untrained_scdp.encoder, untrained_scdp.base.normalizer.goal,
                                        torch.tensor(goals[None], dtype=torch.float32), torch.tensor([0]), torch.zeros(1, 2)))
    assert torch.allclose(film[0][0], legible[0][0]) and torch.allclose(film[1][0], legible[1][0])


def test_scene_frame_by_hand():
    goals = torch.tensor([[[2.0, 0.0], [1.0, 0.5]], [[2.0, 0.0], [1.0, 0.5]]])  # the same scene, target 0 / target 1
    frame = scene_frame(goals, torch.tensor([0, 1]), torch.zeros(2, 2))
    d = np.sqrt(1.25)  # |(1, 0.5)|: the scale is ||g* - p|| + ||g⁻ - p|| = 2 + d for target 0
    assert torch.allclose(frame[0], torch.tensor([1.0, 0.5]) / (2 + d))  # ahead, to the left
    # seen towards (1, 0.5), the point (2, 0) is ahead and to the right
    assert torch.allclose(frame[1], torch.tensor([2.0 / d, -1.0 / d], dtype=torch.float32) / (d + 2), atol=1e-6)
    mirrored = scene_frame(goals * torch.tensor([1.0, -1.0]), torch.tensor([0, 1]), torch.zeros(2, 2))
    assert torch.allclose(mirrored[:, 1], -frame[:, 1]) and torch.allclose(mirrored[:, 0], frame[:, 0])


def test_scene_frame_stays_bounded_near_the_goal():
    """Next to g* the features tend to the distractor's bearing instead of growing without bound."""
    goals = torch.tensor([[[2.0, 0.0], [2.0, 0.4]]])
    for gap in (1.0, 1e-2, 1e-5):
        frame = scene_frame(goals, torch.tensor([0]), torch.tensor([[2.0 - gap, 0.0]]))
        assert frame.abs().max() <= 1.0
    assert torch.allclose(frame[0], torch.tensor([0.0, 1.0]), atol=1e-3)  # straight to the left of the heading


def test_training_seed_reseeds_every_part():
    cpu = PRESETS["cpu"]
    seeded = cpu.with_training_seed(3)
    assert {seeded.schedule(p).seed for p in ("base", "ld", "encoder", "style_legible")} == {3}
    assert seeded.for_layout(2).schedule("base").seed == 3 and seeded.overrides
    assert cpu.with_training_seed(0) is cpu


def test_probabilistic_arbitration_follows_eq3(untrained_scdp):
    eq3 = StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, untrained_scdp.predictors, NAVIGATION,
                                 arbitration="probabilistic")
    start = NAVIGATION.start_point[None]
    assert _styles(eq3, start, NAVIGATION.layouts[0], 0) == ["legible"] and _styles(eq3, start, NAVIGATION.layouts[4], 0) == ["efficient"]
    goals = np.array([[3.0, 0.0], [1.0, 0.5]])  # a near distractor off to the side: inside the ellipse, clear by eq. 3
    assert _styles(eq3, start, goals, 0) == ["efficient"] and _styles(untrained_scdp, start, goals, 0) == ["legible"]
    with pytest.raises(Exception, match="arbitration"):
        StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, untrained_scdp.predictors, NAVIGATION, arbitration="coin")


def _trained_looking(predictor, seed):
    """A copy of an untrained predictor with a non-zero head, so its film is not the identity."""
    out = copy.deepcopy(predictor)
    torch.manual_seed(seed)
    torch.nn.init.normal_(out.head.bias, std=0.3)
    return out


def test_film_scale_extrapolates_away_from_the_identity(untrained_scdp):
    legible = _trained_looking(untrained_scdp.predictors["legible"], 0)
    goals, target, pos = torch.tensor(NAVIGATION.layouts[:1], dtype=torch.float32), torch.tensor([0]), torch.zeros(1, 2)
    films = [StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, {"legible": legible}, NAVIGATION,
                                    style="legible", film_scale=s).film(goals, target, np.ones(1), pos) for s in (1.0, 2.0)]
    assert torch.allclose(films[1][0] - 1, 2 * (films[0][0] - 1)) and torch.allclose(films[1][1], 2 * films[0][1])
    assert not torch.allclose(films[0][1], torch.zeros_like(films[0][1]))


def test_style_guidance_changes_nothing_when_the_styles_agree(untrained_scdp):
    same = _trained_looking(untrained_scdp.predictors["legible"], 1)
    obs = Observation(state_hist=torch.zeros(2, 2, 3), position=torch.zeros(2, 2),
                      goals=torch.tensor(NAVIGATION.layouts[:2], dtype=torch.float32), target=torch.tensor([0, 1]))
    plans = []
    for g in (0.0, 2.0):
        policy = StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder, {"legible": same, "efficient": same},
                                        NAVIGATION, style="legible", style_guidance=g)
        plans.append(policy.act(obs, [torch.Generator().manual_seed(i) for i in (5, 6)]).actions)
    assert torch.allclose(plans[0], plans[1], atol=1e-5)
    different = StyleConditionedPolicy(untrained_scdp.base, untrained_scdp.encoder,
                                       {"legible": same, "efficient": _trained_looking(same, 2)}, NAVIGATION, style="legible",
                                       style_guidance=2.0)
    assert not torch.allclose(plans[0], different.act(obs, [torch.Generator().manual_seed(i) for i in (5, 6)]).actions, atol=1e-3)
