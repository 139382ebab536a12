"""Random streams never coincide (scdp.data.scenes.STREAMS): whatever the seeds, the scene
encoder never trains on evaluation or validation scenes, and tuning never sees evaluation scenes."""

import numpy as np
import pytest

from scdp.data.scenes import DEMOS, EVALUATION, STREAMS, VALIDATION, sample_scenes, stream_rng
from scdp.data.windows import SceneData
from scdp.errors import ScdpError
from scdp.evaluation.protocol import scene_sets
from scdp.keys import AMBIGUOUS, CLEAR
from scdp.presets import PRESETS
from scdp.tasks import NAVIGATION


def _keys(scenes):
    return {tuple(np.round(np.asarray(g, dtype=np.float64).ravel(), 9)) for g, _ in scenes}


def test_no_two_streams_share_a_scene_for_any_seeds():
    seeds = range(6)
    drawn = {s: set().union(*(_keys(sample_scenes(NAVIGATION, 50, k, stream=s)) for k in seeds)) for s in STREAMS}
    for a in STREAMS:
        assert len(drawn[a]) == 50 * len(seeds)  # draws within a stream are distinct too
        for b in STREAMS:
            if a < b:
                assert not drawn[a] & drawn[b], (a, b)


def test_training_seed_k_never_trains_the_encoder_on_evaluation_or_validation_scenes():
    """The leak found in issue 21: training seed 1's encoder trained on all evaluation scenes of seed 1."""
    for k in (0, 1, 2):
        preset = PRESETS["cpu"].with_training_seed(k)
        encoder = SceneData(NAVIGATION, 2000, 2, seed=preset.encoder.train.seed)
        seen = _keys(zip(encoder.goals.numpy(), encoder.target.numpy()))
        for stream in (EVALUATION, VALIDATION):
            for seed in (0, 1, 2):
                sets = scene_sets(NAVIGATION, 20, seed, stream=stream)
                assert not seen & _keys(sets[AMBIGUOUS] + sets[CLEAR]), (k, stream, seed)


def test_validation_and_evaluation_sets_differ_for_the_same_seed():
    ev, va = scene_sets(NAVIGATION, 10, 2, stream=EVALUATION), scene_sets(NAVIGATION, 10, 2, stream=VALIDATION)
    assert not _keys(ev[AMBIGUOUS] + ev[CLEAR]) & _keys(va[AMBIGUOUS] + va[CLEAR])


def test_a_stream_is_reproducible_and_named():
    assert np.array_equal(stream_rng(DEMOS, 3).random(4), stream_rng(DEMOS, 3).random(4))
    with pytest.raises(ScdpError, match="stream"):
        stream_rng("tests", 0)
