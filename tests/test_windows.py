"""Tests of scdp.data.windows: the training windows of observations and actions."""

import numpy as np

from scdp.data.windows import WindowData
from scdp.tasks import NAVIGATION


def test_windows_by_hand(small_datasets):
    ds = small_datasets["navigation"]
    w = WindowData(ds, n_obs_steps=2, horizon=4, task=NAVIGATION)
    a, b = ds.episode_bounds(1)
    first = int(np.flatnonzero(w.obs_index[:, -1].numpy() == a)[0])
    assert w.obs_index[first].tolist() == [a, a]  # the first state repeated before the start
    assert w.action_index[first].tolist() == [a, a, a + 1, a + 2]
    last = int(np.flatnonzero(w.obs_index[:, -1].numpy() == b - 1)[0])
    assert w.action_index[last].tolist() == [b - 2, b - 1, b - 1, b - 1]  # goal held after the end
    assert len(w) == ds.num_steps
