"""The ``scdp`` data commands' arguments and help text (assembled by :mod:`scdp.cli.parser`).

Standard library and scdp's light leaves only, as the parser, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp.cli.parser_common import goals_arg, task_arg
from scdp.cli.types import count, point, seed
from scdp.keys import SCENE_MODES, TURN_FROM


def _generate(sub) -> None:
    """``generate``: its arguments and help."""
    p = sub.add_parser("generate", help="generate Bézier demonstrations in simulation into a zarr replay buffer",
                       description="Draw quadratic Bézier paths, execute them in the task's simulator, and store the successful ones.")
    task_arg(p)
    p.add_argument("--num-demos", type=count, default=200, help="number of successful demos (default 200)")
    p.add_argument("--seed", type=seed, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--scenes", choices=SCENE_MODES, default="random", metavar="{random,fixed,layout_1..layout_6}",
                   help="random goals per demo (default), the authors' six fixed layouts in turn, "
                        "or one of them only (layout_k, as in the per-layout protocol)")
    goals_arg(p, "default 2; the layouts hold 2")
    p.add_argument("--turning", type=float, default=0.0, metavar="SHARE",
                   help="share of demos whose path changes course part-way (0..1, default 0): followed up to a drawn "
                        "15-70 %% of the way, then bending anew to the goal without a kink, so that a style chosen "
                        "mid-motion has demonstrations to learn from")
    p.add_argument("--turn-from", choices=TURN_FROM, default="start",
                   help="where a turning demo's second course starts: another demo curve from the start, blended in "
                        "slowly (start, default), or a fresh curve from the turn itself, bending for the rest of the way (point)")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:generate")


def _inspect(sub) -> None:
    """``inspect``: its arguments and help."""
    p = sub.add_parser("inspect", help="print counts, lengths and curvature spread of a dataset")
    p.add_argument("path", help="a .zarr dataset")
    p.set_defaults(handler="data:inspect")


def _plot_demos(sub) -> None:
    """``plot-demos``: its arguments and help."""
    p = sub.add_parser("plot-demos", help="draw a dataset's paths over their scenes")
    p.add_argument("path", help="a .zarr dataset")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.add_argument("--max-demos", type=count, default=50, help="how many demos to draw (default 50)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:plot_demos")


def _import_hdf5(sub) -> None:
    """``import-hdf5``."""
    p = sub.add_parser("import-hdf5", help="import robomimic-style HDF5 demonstrations into zarr",
                       description="Import demonstrations whose actions are absolute next states. Steps after a "
                                   "'dones' flag and trailing actions beyond the robot's one-step reach (e.g. an "
                                   "all-zero terminal sentinel) are dropped with a warning; such a step anywhere "
                                   "else is refused.")
    p.add_argument("path", help="HDF5 file with data/demo_k/{states, actions, obs/object} and optional dones")
    task_arg(p)
    p.add_argument("--goal-dim", type=int, default=None, metavar="N",
                   help="coordinates per goal in obs/object (default: the task's space, 2 or 3; "
                        "use 2 for Block Reach goals given on the table plane)")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="data:import_hdf5")


def _import_lerobot(sub) -> None:
    """``import-lerobot``: its arguments and help."""
    p = sub.add_parser("import-lerobot", help="import a LeRobot v3 dataset (parquet + meta/info.json) into zarr",
                       description="Read a LeRobot v3 dataset with pyarrow (pip install 'scdp[lerobot]'), without the "
                                   "lerobot package. The state and action features must hold the task's state (or "
                                   "--action-from next-state builds each action from the next frame's state: recordings "
                                   "of velocity commands or of states only); the goals come from --goals-feature "
                                   "(observation.environment_state where present, g* first), or from the task (g* where "
                                   "each episode ends, one distractor from the task's sampler). Each episode's task text, "
                                   "the fps, robot_type and feature names are kept for a later export-demos. "
                                   "docs/data.md shows the mapping.")
    p.add_argument("path", help="the dataset's folder (holding meta/info.json and data/)")
    task_arg(p)
    p.add_argument("--state-feature", default="observation.state", help="the state feature (default observation.state)")
    p.add_argument("--action-feature", default="action", help="the action feature: absolute next states (default action)")
    p.add_argument("--action-from", choices=("feature", "next-state"), default="feature",
                   help="where each action comes from: the action feature (default), or next-state: the next frame's "
                        "state (the last frame holds still), for recordings without absolute-state actions")
    p.add_argument("--goals-feature", help="a feature holding every goal's coordinates, flattened (read at an episode's "
                                           "first frame); default observation.environment_state where present, else "
                                           "the task's")
    p.add_argument("--target-feature", help="a feature holding g*'s index among the goals (default: g* is the first; "
                                            "scdp's exports say where it stood in target_index)")
    p.add_argument("--goal-dim", type=int, default=None, metavar="N", help="coordinates per goal (default: the task's space)")
    p.add_argument("--out", required=True, help="output .zarr folder")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="lerobot:import_lerobot")


def _export_demos(sub) -> None:
    """``export-demos``: its arguments and help."""
    p = sub.add_parser("export-demos", help="write demonstrations (zarr) in another format: LeRobot v3",
                       description="Write a demos.zarr as a LeRobot v3 dataset: meta/info.json, meta/episodes, "
                                   "meta/tasks, meta/stats.json (with quantiles) and the data parquet, timestamps "
                                   "relative to each episode; the goals in observation.environment_state (g* first), "
                                   "where LeRobot's policies read the environment. A dataset imported from LeRobot keeps "
                                   "its fps, robot_type, task texts and feature names unless set here. "
                                   "Needs pyarrow (pip install 'scdp[lerobot]').")
    p.add_argument("demos", help="a demos .zarr folder")
    p.add_argument("--format", choices=("lerobot",), default="lerobot", help="the format written (lerobot: v3)")
    p.add_argument("--fps", type=float, default=None,
                   help="frames per second recorded in info.json (default: the imported dataset's, else 10)")
    p.add_argument("--task-text", default=None, help="every episode's task text, read by language-conditioned policies "
                                                     "(default: the imported dataset's, else 'reach the target goal')")
    p.add_argument("--robot-type", default=None, help="info.json's robot_type (default: the imported dataset's, else the "
                                                      "task's name)")
    p.add_argument("--out", required=True, help="the dataset folder to write")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="lerobot:export_demos")


def _ambiguity_report(sub) -> None:
    """``ambiguity-report``: its arguments and help."""
    p = sub.add_parser("ambiguity-report", help="calibrate ambiguity and compare the ellipse with eq. 3 on random scenes")
    task_arg(p)
    p.add_argument("--scenes", type=count, default=10_000, help="random scenes to compare on (default 10000)")
    p.add_argument("--seed", type=seed, default=0, help="seed of the random scenes (default 0)")
    p.add_argument("--out", help="write the report as JSON here (and Markdown beside it)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="ambiguity:report")


def _plot_ellipse(sub) -> None:
    """``plot-ellipse``: its arguments and help."""
    p = sub.add_parser("plot-ellipse", help="draw the ellipse of ambiguity for one scene (the paper's Fig. 4b)")
    task_arg(p)
    p.add_argument("--goals", type=point, nargs="+", required=True, help="goals as x,y (or x,y,z) ...")
    p.add_argument("--target", type=int, default=0, help="index of g* among --goals (default 0)")
    p.add_argument("--out", required=True, help="image file (.png or .pdf)")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.set_defaults(handler="ambiguity:plot_ellipse")


def add_data_parsers(sub) -> None:
    """``scdp generate | inspect | plot-demos | import-hdf5 | import-lerobot | export-demos | ambiguity-report | plot-ellipse``."""
    for add in (_generate, _inspect, _plot_demos, _import_hdf5, _import_lerobot, _export_demos, _ambiguity_report, _plot_ellipse):
        add(sub)

