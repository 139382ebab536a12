"""The hostile inputs of issue 22 on the command line, each refused on its exact field.

Same sandbox and rules as :mod:`test_fuzz_cli` (exit 2, one line ``scdp: error: <field>: <problem>``,
no traceback, nothing written), but the field must match exactly. Defects covered: styles given
to methods without a choice (3), links out of an HDF5 file (4), writers and resumes (5), messages
that named the wrong cause or split the line (6), and the smaller acceptances (7). The planner
guards of defect 1 outside the service (the policy's inputs, deploy's last check) close the file.
"""

import subprocess
import sys
import warnings

import h5py
import numpy as np
import pytest
from test_fuzz_cli import (  # noqa: F401
    EVAL,
    NAV,
    PLAN,
    TRAIN,
    Case,
    damage_zarr,
    demo_group,
    edit_config,
    h5,
    pristine,
    refused_line,
    run_case,
    set_value,
)

from helpers.stubs import StubPlanner
from scdp.cli import main
from scdp.errors import ScdpError
from scdp.policies.base import observe_histories
from scdp.tasks import BLOCK_REACH, NAVIGATION

TINY = ["--preset", "tiny"]


def one_step_episodes(arrays, attrs):
    """Every episode cut to its first step (a dataset import-hdf5 would refuse)."""
    ends = arrays["meta/episode_ends"]
    starts = np.concatenate([[0], ends[:-1]])
    for key in ("data/state", "data/action", "data/goal", "data/goals"):
        arrays[key] = arrays[key][starts]
    arrays["meta/episode_ends"] = np.arange(1, len(ends) + 1)


def flat_normalizer(meta):
    meta["normalizer"]["action"]["high"] = list(meta["normalizer"]["action"]["low"])


def link(name, target):
    def build(f, ep):
        f.require_group("data")[name] = target
    return build


def linked_member(key, target):
    def build(f, ep):
        g = demo_group(f, ep, skip=(key,))
        g[key] = target
    return build


def state_row(value):
    def build(f, ep):
        states = ep["state"].copy()
        states[3, 0] = value
        demo_group(f, ep, states=states)
    return build


IMPORT = ["import-hdf5", "{S}/bad.hdf5", *NAV, "--out", "{S}/i.zarr"]
CASES = [
    # 3: a style is never ignored
    Case("plan dp with a style", [*PLAN, "--method", "dp", "--style", "legible"], "--style"),
    Case("plan ld with a style", [*PLAN, "--method", "ld", "--style", "auto"], "--style"),
    Case("plan scdp_paper with a style", [*PLAN, "--method", "scdp_paper", "--style", "legible"], "--style"),
    Case("plan scdp_legible with another style", [*PLAN, "--method", "scdp_legible", "--style", "efficient"], "--style"),
    # 4: links that do not resolve inside the file
    Case("import demo linked to itself", IMPORT, "data/demo_0", h5(link("demo_0", h5py.SoftLink("/data/demo_0")))),
    Case("import demo linked nowhere", IMPORT, "data/demo_0", h5(link("demo_0", h5py.SoftLink("/data/gone")))),
    Case("import demo in a missing file", IMPORT, "data/demo_0",
         h5(link("demo_0", h5py.ExternalLink("missing.hdf5", "/data/demo_0")))),
    Case("import states linked to themselves", IMPORT, "data/demo_0/states",
         h5(linked_member("states", h5py.SoftLink("/data/demo_0/states")))),
    Case("import goals in a missing file", IMPORT, "data/demo_0/obs/object",
         h5(linked_member("obs/object", h5py.ExternalLink("missing.hdf5", "/x")))),
    # 5: writers and resumes
    Case("reproduce into strangers", ["reproduce", *TINY, "--out", "{S}/strangers"], "--out"),
    Case("reproduce into a dataset", ["reproduce", *TINY, "--out", "{S}/demos.zarr"], "--out"),
    Case("reproduce layouts repeated", ["reproduce", *TINY, "--protocol", "per_layout", "--layouts", "2", "2",
                                        "--out", "{S}/r"], "--layouts"),
    Case("reproduce layouts on random", ["reproduce", *TINY, "--layouts", "2", "--out", "{S}/r"], "--layouts"),
    Case("evaluate dp twice", [*EVAL[:-1], "dp", "dp"], "--methods"),
    Case("evaluate one planner, two names", [*EVAL[:-1], "dp", "scdp_legible", "scdp:legible"], "--methods"),
    Case("evaluate scdp and scdp:auto", [*EVAL[:-1], "dp", "scdp", "scdp:auto"], "--methods"),
    Case("resume another part's run", ["train", "ld", *NAV, *TINY, "--data", "{S}/demos.zarr", "--out", "{S}/partial",
                                       "--resume"], "--resume"),
    Case("resume another task's run", ["train", "base", "--task", "block_reach", *TINY, "--data", "{S}/demos.zarr",
                                       "--out", "{S}/partial", "--resume"], "--resume"),
    Case("train over another part", ["train", "ld", *NAV, *TINY, "--data", "{S}/demos.zarr", "--out", "{S}/ckpt/base"],
         "--out"),
    # 6: the real cause, on one line
    Case("import 1e30 state", IMPORT, "data/demo_0/states", h5(state_row(1e30))),
    Case("import 1e308 state", IMPORT, "data/demo_0/states", h5(state_row(1e308))),
    Case("plan 1e308 goal", [*PLAN[:6], "1e308,0.3", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("flat normaliser", [*PLAN, "--method", "dp"], "checkpoints/base",
         edit_config("base", flat_normalizer)),  # config.json normalizer/action
    Case("newline in a path", ["inspect", "{S}/new\nline.zarr"], "dataset"),
    Case("newline in a checkpoints path", [*PLAN[:4], "{S}/no\nckpt", *PLAN[5:]], "--checkpoints"),
    Case("a 100 kB method", [*PLAN, "--method", "x" * 100_000], "--method"),
    Case("a 100 kB goal", [*PLAN[:6], "a" * 100_000, "2,-0.3", "--out", "{S}/p.json"], "--goals"),
    # 7: smaller acceptances
    Case("unknown top-level key", [*PLAN, "--method", "dp"], "checkpoints/base", edit_config("base", lambda m: m.update(wings=2))),
    Case("threads absurd", ["--threads", "100000000", "inspect", "{S}/demos.zarr"], "--threads"),
    Case("plot-demos max 0", ["plot-demos", "{S}/demos.zarr", "--max-demos", "0", "--out", "{S}/d.png"], "--max-demos"),
]
for command, argv in {"inspect": ["inspect", "{S}/demos.zarr"], "train": TRAIN,
                      "plot-demos": ["plot-demos", "{S}/demos.zarr", "--out", "{S}/d.png"]}.items():
    CASES += [Case(f"{command}: 1e30 state", argv, "data/state", damage_zarr(set_value("data/state", (7, 0), 1e30))),
              Case(f"{command}: 1-step episodes", argv, "meta/episode_ends", damage_zarr(one_step_episodes))]


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_hostile_input_is_refused_on_its_exact_field(case, pristine, tmp_path, capsys):  # noqa: F811 (the pytest fixture imported from test_fuzz_cli)
    line = refused_line(case, pristine, tmp_path, capsys)
    assert len(line) < 700 and "x" * 100 not in line and "a" * 100 not in line  # never a long bad value echoed


def test_resume_refusals_name_what_the_folder_holds_and_never_advise_force(pristine, tmp_path, capsys):  # noqa: F811 (the pytest fixture imported from test_fuzz_cli)
    for case in CASES:
        if case.field == "--resume":
            code, err = run_case(pristine, case.argv, capsys)
            assert code == 2 and "'base' run of task 'navigation'" in err and "--force" not in err, err


def test_warnings_on_the_way_to_a_refusal_are_not_printed(pristine):  # noqa: F811 (the pytest fixture imported from test_fuzz_cli)
    """A separate process: pytest would capture the warnings themselves."""
    argv = [a.replace("{S}", str(pristine)) for a in [*PLAN[:6], "1e308,1e308", "2,-0.3", "--out", "{S}/p.json"]]
    done = subprocess.run([sys.executable, "-W", "always", "-m", "scdp", *argv], capture_output=True, text=True, timeout=180)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr[-600:]
    assert done.stderr.startswith("scdp: error: goals: ")


def test_huge_goals_are_refused_before_any_arithmetic_could_overflow():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning would be raised here instead of the refusal
        with pytest.raises(ScdpError) as err:
            NAVIGATION.validate_goals([[1e308, 1e308], [-1e308, 2.0]])
    assert err.value.field == "goals"


def test_runtime_warnings_before_a_refusal_are_dropped_and_shown_after_a_success(monkeypatch, recwarn):
    import scdp.cli.data as data

    def refused(args):
        np.float64(1e308) * np.float64(10.0)  # overflows: a RuntimeWarning
        raise ScdpError("dataset", "refused")

    def succeeded(args):  # another line: a warning once dropped is not repeated from the same place
        np.float64(1e308) * np.float64(10.0)
        return 0

    monkeypatch.setattr(data, "inspect", refused)
    assert main(["inspect", "x.zarr"]) == 2
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]
    monkeypatch.setattr(data, "inspect", succeeded)
    assert main(["inspect", "x.zarr"]) == 0
    assert [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


# -- defect 1 beyond the service: the policy's inputs and deploy's last check --------------------------------
@pytest.mark.parametrize("task, state", [(NAVIGATION, [1e308, 1e308, 0.0]), (NAVIGATION, [100.0, 100.0, 0.0]),
                                         (NAVIGATION, [np.nan, 0.0, 0.0]), (BLOCK_REACH, [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0])])
def test_a_planner_is_never_asked_to_plan_from_an_impossible_state(task, state):
    goals = task.layouts[0]
    with pytest.raises(ScdpError) as err:
        observe_histories(task, [[state]], [goals], [0], 2)
    assert err.value.field == "state"


@pytest.mark.parametrize("make", [lambda q: np.full((4, 7), np.nan), lambda q: np.full((4, 7), np.inf),
                                  lambda q: np.stack([q, q, q + [0, 0, np.nan, 0, 0, 0, 0], q])], ids=["nan", "inf", "one nan"])
def test_deploy_refuses_a_chunk_that_is_not_finite(make):
    """Joint range and speed are the streamer's (clip to the limits, then jerk-limited time scaling); a
    NaN or inf would pass through both."""
    from scdp.deploy import deploy_scene
    from scdp.perception import ColorDetector, block_reach_camera

    with pytest.raises(ScdpError) as err:
        deploy_scene(BLOCK_REACH, StubPlanner(make), 4, camera=block_reach_camera(), detector=ColorDetector())
    assert err.value.field == "actions"
