"""Import robomimic-style HDF5 demonstrations (the authors' format).

Expected layout::

    data/demo_<k>/states       (T, state_dim)
    data/demo_<k>/actions      (T, state_dim)   the next state
    data/demo_<k>/obs/object   (T, n_goals * goal_dim) or (n_goals * goal_dim,)  g* first, then g-

Goals may be given with fewer coordinates than the task's space (Block Reach goals in xy
get z = 0.1); they are read from the first step of each demo. Demos are imported in
numeric order of ``k``.
"""

from __future__ import annotations

import re
from pathlib import Path

import h5py
import numpy as np

from scdp.data.dataset import DemoDataset
from scdp.errors import ScdpError
from scdp.tasks import get_task


def import_robomimic(path, task, *, goal_dim: int | None = None) -> DemoDataset:
    """Read an HDF5 file into a :class:`DemoDataset` (g* is goal 0 of every demo).

    ``goal_dim`` is the number of coordinates per goal in ``obs/object``; by default the
    task's space dimension.
    """
    task = get_task(task)
    path = Path(path)
    if not path.exists():
        raise ScdpError("hdf5", f"{path} does not exist")
    goal_dim = goal_dim or task.space_dim
    episodes = []
    try:
        with h5py.File(path, "r") as f:
            if "data" not in f:
                raise ScdpError("hdf5", f"{path} has no 'data' group")
            names = sorted((n for n in f["data"] if re.fullmatch(r"demo_\d+", n)), key=lambda n: int(n[5:]))
            if not names:
                raise ScdpError("hdf5", f"{path} has no data/demo_<k> groups")
            for name in names:
                demo = f["data"][name]
                for key in ("states", "actions", "obs/object"):
                    if key not in demo:
                        raise ScdpError(f"data/{name}/{key}", "missing")
                states = np.asarray(demo["states"], dtype=np.float64)
                actions = np.asarray(demo["actions"], dtype=np.float64)
                obj = np.asarray(demo["obs/object"], dtype=np.float64)
                if states.ndim != 2 or states.shape[1] != task.state_dim:
                    raise ScdpError(f"data/{name}/states", f"expected (T, {task.state_dim}), got {states.shape}")
                if actions.shape != states.shape:
                    raise ScdpError(f"data/{name}/actions", f"expected {states.shape}, got {actions.shape}")
                first = obj[0] if obj.ndim == 2 else obj
                if first.size % goal_dim:
                    raise ScdpError(f"data/{name}/obs/object", f"{first.size} values do not split into goals of {goal_dim}")
                goals = task.validate_goals(first.reshape(-1, goal_dim), 0, field=f"data/{name}/obs/object")
                if not np.all(np.isfinite(states)) or not np.all(np.isfinite(actions)):
                    raise ScdpError(f"data/{name}", "contains NaN or inf")
                episodes.append({"state": states, "action": actions, "goals": goals, "target": 0})
    except OSError as exc:
        raise ScdpError("hdf5", f"{path} is not a readable HDF5 file ({exc})") from None
    return DemoDataset.from_episodes(task.name, episodes, {"source": f"robomimic:{path.name}"})
