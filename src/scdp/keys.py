"""Named constants shared across layers: methods, parts, styles, scene modes, layouts.

A leaf module with no imports, so that the command line can build its ``--help`` from it
without loading torch or MuJoCo.
"""

# The authors' six fixed goal pairs are *layouts*, numbered 1..6.
LAYOUT_IDS = range(1, 7)
_LAYOUT_PREFIX = "layout_"


def layout_name(k: int) -> str:
    """The scene set (and per-layout folder) of layout ``k``: ``layout_3``."""
    return f"{_LAYOUT_PREFIX}{k}"


def layout_number(name: str) -> int | None:
    """The layout a scene set names (``layout_3`` -> 3), None for any other scene set."""
    rest = name.removeprefix(_LAYOUT_PREFIX) if isinstance(name, str) else ""
    return int(rest) if rest != name and rest.isdigit() else None


LAYOUTS = tuple(layout_name(k) for k in LAYOUT_IDS)
AMBIGUOUS_LAYOUTS = "layouts_ambiguous"  # layouts 1-3 grouped, as the authors labelled them
CLEAR_LAYOUTS = "layouts_clear"  # layouts 4-6

# Where the demonstrations' goals come from.
SCENE_MODES = ("random", "fixed", *LAYOUTS)
# How a scene may change during a motion (scdp.data.scenes.SceneEvent, scdp.evaluation.dynamic).
EVENT_KINDS = ("appear", "vanish", "move")

# Random evaluation scene sets, labelled by eq. 3 at the start.
AMBIGUOUS, CLEAR = "ambiguous", "non_ambiguous"

# Styles of SCDP: the two predictors, and how a chunk's style is chosen.
STYLES = ("legible", "efficient")
ARBITRATIONS = ("ellipse", "probabilistic")  # how SCDP's auto mode decides a chunk's style
EFFICIENT_SCORES = ("e_hat", "transparency")  # how the efficient predictor's demos are ranked
# which windows a style predictor learns from: those of its top demos, or the steps whose remaining path is
# the most legible (efficient) within each tenth of the motion (scdp.scoring.rest)
STYLE_WINDOWS = ("demos", "rest")
# where a turning demo's second course starts: another curve from the start, or one from the turn (scdp.data.bezier)
TURN_FROM = ("start", "point")
# how the legible predictor's demos are ranked: the paper's detachment, or what the path-length observer
# reads, in task space or as the task's viewer sees the motion (scdp.scoring.subsets)
LEGIBLE_SCORES = ("d_hat", "legibility", "viewpoint_legibility", "pareto", "rank_mean")
SAMPLERS = ("ddpm", "ddim", "dpmsolver")  # planning-time samplers: DDPM and DDIM (scdp's own steps), diffusers' DPM-Solver
BETA_SCHEDULES = ("linear", "scaled_linear", "squaredcos_cap_v2")  # the training noise schedules (diffusers' names)
STYLE_MODES = ("auto", "blend", "legible", "efficient", "none")


def styles_needed(mode: str) -> frozenset[str]:
    """The style predictors an SCDP style mode plans with: both for ``auto`` and ``blend``, its own
    for a forced style, none for ``none``."""
    return frozenset(STYLES) if mode in ("auto", "blend") else frozenset({mode}) - {"none"}
# How D and E (and j) are brought to a common scale for T: over the scene's reference set (scdp's), or over
# the task's training demonstrations (the paper's wording); every verdict is reported under both
# (scdp.scoring.normalisation).
SCENE_NORMALISATION, DATASET_NORMALISATION = "scene", "dataset"
NORMALISATIONS = (SCENE_NORMALISATION, DATASET_NORMALISATION)
RUNTIMES = ("torch", "onnx", "auto")  # what runs the denoiser at planning time

# The order a model set trains its parts in, one checkpoint folder each (the encoder is trained once per task);
# which parts it trains is what its evaluated planners train (scdp.planners.PlannerKind.trains).
STUDENT_PART = "student"  # the few-step student distilled from the base (scdp.training.distill)
MODEL_PARTS = ("base", "style_legible", "style_efficient", STUDENT_PART, "ld")
# The paper's own design of the two predictors, on the same base: trained when ``scdp_paper`` is evaluated.
PAPER_METHOD = "scdp_paper"
DESIGNS = {"scdp": "style_", PAPER_METHOD: "style_paper_"}  # each design's predictor parts: prefix + style


def style_part(style: str, design: str = "scdp") -> str:
    """The checkpoint part of one style's predictor: ``style_legible``, or ``style_paper_legible`` for
    the paper's design (``design`` is ``scdp`` or :data:`PAPER_METHOD`)."""
    return DESIGNS[design] + style


def part_design(part: str) -> str | None:
    """The design a style part belongs to (``scdp`` or :data:`PAPER_METHOD`), None for another part."""
    return next((d for d in (PAPER_METHOD, "scdp") if part in {style_part(s, d) for s in STYLES}), None)


def is_style_part(part: str) -> bool:
    """Whether ``part`` is a style predictor's checkpoint part (either design)."""
    return part_design(part) is not None


def part_style(part: str) -> str:
    """The style of a style predictor's part: ``style_paper_legible`` -> ``legible``."""
    design = part_design(part)
    if design is None:
        raise ValueError(f"{part!r} is not a style part")
    return part.removeprefix(DESIGNS[design])


PAPER_STYLE_PARTS = tuple(style_part(s, PAPER_METHOD) for s in STYLES)

# Names of scdp's own planners (what each is: scdp.planners): LD with tuned or the authors' guidance,
# SCDP's arbitration modes and forced styles.
SCDP_METHODS = {"scdp": "auto", "scdp_blend": "blend", "scdp_legible": "legible", "scdp_efficient": "efficient",
                "scdp_none": "none"}
LD_METHODS = ("ld", "ld_paper")  # Legibility Diffuser: tuned guidance, the authors'

# Reproduction protocols: one model set per task trained on random scenes, or the authors'
# one model set per layout.
RANDOM, PER_LAYOUT = "random", "per_layout"
PROTOCOLS = (RANDOM, PER_LAYOUT, "both")
LOCAL, RAY = "local", "ray"  # where reproduce's independent units run (scdp.pipeline.executor)
EXECUTORS = (LOCAL, RAY)

TASK_NAMES = ("navigation", "block_reach")

# Goals in one scene: a target and one to four distractors (2 is the paper's; up to 5 is checked everywhere).
MIN_GOALS, MAX_GOALS = 2, 5
