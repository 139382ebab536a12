"""What ``scdp inspect`` reports about a dataset: counts, lengths and how much the paths bend."""

from __future__ import annotations

import numpy as np

from scdp.data.bezier import signed_bend

PERCENTILES = (0, 10, 25, 50, 75, 90, 100)


def dataset_stats(dataset) -> dict:
    """Counts, episode lengths and the spread of signed path bend (see :func:`signed_bend`)."""
    task = dataset.task_object()
    lengths = dataset.episode_lengths()
    bends = np.array([signed_bend(task.episode_path(dataset.episode(i))) for i in range(dataset.num_episodes)])
    return {
        "task": dataset.task,
        "episodes": int(dataset.num_episodes),
        "steps": int(dataset.num_steps),
        "length": {"min": int(lengths.min()), "mean": round(float(lengths.mean()), 1), "max": int(lengths.max())},
        "bend_percentiles": {f"p{k}": round(float(v), 3) for k, v in zip(PERCENTILES, np.percentile(bends, PERCENTILES))},
        "bend_abs_mean": round(float(np.abs(bends).mean()), 3),
        "left_right": [int(np.sum(bends > 0)), int(np.sum(bends < 0))],
        "goals_per_scene": int(dataset.goals.shape[1]),
        "seed": dataset.attrs.get("seed"),
    }
