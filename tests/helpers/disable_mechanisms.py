"""Re-run the behaviour fixture's evaluation with one mechanism switched off at planning time.

    python3 tests/helpers/disable_mechanisms.py RUN VARIANT OUT
    SCDP_CI_RUN=OUT python3 -m pytest tests/test_behaviour.py   # the test that must now fail

RUN: a finished `scdp reproduce --task navigation --preset ci --out RUN`; VARIANT: films (identity
γ, β), arbitration (scdp always efficient), guidance (LD with w0 = 0) or untrained (DP re-initialised).
Same checkpoints, scenes (evaluation stream, seed 1, 20 + 20) and noise as the fixture.
"""
import json
import sys
from pathlib import Path

import numpy as np
import torch

from scdp.config import GuidanceConfig
from scdp.evaluation.protocol import evaluate_methods, scene_sets
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.models.film import Film
from scdp.models.style_predictor import StylePredictor
from scdp.policies.loaders import load_ld, load_method
from scdp.policies.scdp import StyleConditionedPolicy
from scdp.tasks import NAVIGATION as task

ck = Path(sys.argv[1]) / "navigation" / "checkpoints"
variant = sys.argv[2]
assert variant in ("films", "arbitration", "guidance", "untrained"), variant
sets = {k: v for k, v in scene_sets(task, 20, 1).items() if k in (AMBIGUOUS, CLEAR)}
if variant == "films":
    StylePredictor.forward = lambda self, x: Film.identity(x.shape[0], self.config.film_width, self.config.film_blocks)
if variant == "arbitration":
    orig = StyleConditionedPolicy.legible_weights
    StyleConditionedPolicy.legible_weights = lambda self, p, g, t: np.zeros(len(t)) if self.style == "auto" else orig(self, p, g, t)
planners = {m: load_method(m, ck, task) for m in ("dp", "ld", "scdp", "scdp_legible", "scdp_efficient")}
if variant == "guidance":
    planners["ld"] = load_ld(ck / "ld", task, GuidanceConfig(w0=0.0))
if variant == "untrained":
    torch.manual_seed(0)
    for mod in planners["dp"].unet.modules():
        if hasattr(mod, "reset_parameters"):
            mod.reset_parameters()
records = evaluate_methods(task, planners, sets, seed=1, progress=False)
out = Path(sys.argv[3])
out.mkdir(parents=True, exist_ok=True)
(out / "results.json").write_text(json.dumps({"trajectories": [{**r.to_dict(), "protocol": "random"} for r in records]}))
