"""Flags several ``scdp`` commands share (the subject modules ``parser_*`` add them).

Standard library and scdp's light leaves only, as the parser, so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp.cli.types import count
from scdp.config.planning import DEVICE_FLAG, ENTRY_PROFILES, PlanningOptions
from scdp.keys import EXECUTORS, TASK_NAMES

TASK_HELP = (f"{' or '.join(TASK_NAMES)}; a task of your own as package.module:OBJECT (looked up from the "
             "working directory), or the name of an installed one (entry point group scdp.tasks): docs/tasks.md")


def task_arg(p, **kw):
    p.add_argument("--task", required=True, help=TASK_HELP, **kw)


def device_arg(p):
    p.add_argument("--device", **DEVICE_FLAG)


def planning_args(p, entry: str):
    """The planning-time options: one flag per field of :class:`scdp.config.PlanningOptions`, with the
    ``--profile`` of ``entry`` (:data:`scdp.config.planning.ENTRY_PROFILES`) as its default."""
    for flag, keywords in PlanningOptions.flags(ENTRY_PROFILES[entry]):
        p.add_argument(flag, **keywords)


def set_arg(p):
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.FIELD=VALUE",
                   help="override one preset field, e.g. --set base.train.lr=3e-4 --set style.model.layers=3 "
                        "(sections: data, base, encoder, style, ld, evaluation, layouts; values are JSON); "
                        "recorded in every checkpoint and in results.json")


def goals_arg(p, what: str):
    p.add_argument("--goals", type=int, default=None, metavar="N",
                   help=f"goals per random scene, 2..5: the target and N-1 distractors ({what})")



def executor_args(p, units: str = "every independent unit"):
    """--executor, --ray-address, --workers: where a command's independent units run
    (:mod:`scdp.pipeline.executor`; ``reproduce``, and the benchmarks that sweep or compare)."""
    p.add_argument("--executor", default="local", choices=list(EXECUTORS),
                   help=f"local (default): one after another in this process. ray: {units} a Ray task on the cluster "
                        "at --ray-address, or on a Ray started here; pip install 'scdp[cluster]', see docs/cluster.md")
    p.add_argument("--ray-address", metavar="ADDR",
                   help="the Ray cluster to join (e.g. auto, or ray://head:10001; default: start one on this machine)")
    p.add_argument("--workers", type=count, metavar="N",
                   help="CPUs of the Ray started here (default: this machine's); a cluster's are its own")
