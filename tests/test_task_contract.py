"""Tests of scdp.tasks (the resolver: module:OBJECT, entry points) and scdp.tasks.contract: a task
from outside the library is found by every command, and one that breaks its contract is refused at
load in one line naming the member."""


import numpy as np
import pytest

from helpers.refusals import refused_at_load, user_module
from scdp import tasks
from scdp.errors import ScdpError
from scdp.tasks import BLOCK_REACH, NAVIGATION, get_task
from scdp.tasks.contract import check_contract

# a module of the user's own, written into a folder the test makes the working directory
USER_MODULE = '''
from dataclasses import dataclass, replace
import numpy as np
from scdp.envs.navigation import NavigationEnv
from scdp.tasks import NAVIGATION, NavigationTask, Task

GOOD = replace(NAVIGATION, name="my_rover")
make_good = lambda: replace(NAVIGATION, name="my_rover_2")
NOT_A_TASK = 42
BAD_LAYOUTS = replace(NAVIGATION, name="bad_layouts", layouts=np.zeros((5, 2, 2)))
BAD_BOX = replace(NAVIGATION, name="bad_box", goal_high=np.array([9.0, 1.5]))
BAD_NAME = replace(NAVIGATION, name="My Rover")
BAD_LABELS = replace(NAVIGATION, name="bad_labels", ambiguous_layouts=(0, 7))
_close = np.array(NAVIGATION.layouts); _close[2] = [[1.5, 0.1], [1.5, 0.12]]
CLOSE_LAYOUT = replace(NAVIGATION, name="close_layout", layouts=_close)
_start = np.array(NAVIGATION.layouts); _start[4, 1] = [0.05, 0.0]
START_LAYOUT = replace(NAVIGATION, name="start_layout", layouts=_start)
# lists where the library keeps arrays: read as numbers, and the task works
AS_LISTS = replace(NAVIGATION, name="as_lists", goal_low=list(NAVIGATION.goal_low), goal_high=tuple(NAVIGATION.goal_high),
                   layouts=np.asarray(NAVIGATION.layouts).tolist())
WORDS = replace(NAVIGATION, name="words", goal_low=["a", "b"])

@dataclass(frozen=True, eq=False)
class NanBound(NavigationTask):
    def state_bounds(self):
        low, high = NavigationTask.state_bounds(self)
        return low, np.where(np.arange(3) == 1, np.nan, high)

@dataclass(frozen=True, eq=False)
class Inverted(NavigationTask):
    def state_bounds(self):
        low, high = NavigationTask.state_bounds(self)
        return np.where(np.arange(3) == 2, high, low), np.where(np.arange(3) == 2, low, high)

@dataclass(frozen=True, eq=False)
class Flat(NavigationTask):
    def task_space(self, states):  # the wrong shape: every coordinate, not the task-space point
        return np.asarray(states, dtype=np.float64)

@dataclass(frozen=True, eq=False)
class NoReach(Task):  # a robot that never says how far a step reaches
    task_space = NavigationTask.task_space
    nominal_start = NavigationTask.nominal_start
    actions_for_path = NavigationTask.actions_for_path
    make_env = NavigationTask.make_env
    state_bounds = NavigationTask.state_bounds
    state_names = NavigationTask.state_names

def _fields(name):
    return {k: getattr(NAVIGATION, k) for k in NAVIGATION.__dataclass_fields__} | {"name": name}

WRONG_SHAPE = Flat(**_fields("wrong_shape"))
MISSING = NoReach(**_fields("missing"))
class ShortStateEnv(NavigationEnv):
    @property
    def state(self):  # drops the heading
        return NavigationEnv.state.fget(self)[:2]

@dataclass(frozen=True, eq=False)
class ShortState(NavigationTask):
    def make_env(self, **kwargs):
        return ShortStateEnv(self, **kwargs)

SHORT_STATE = ShortState(**_fields("short_state"))
NAN_BOUND = NanBound(**_fields("nan_bound"))
INVERTED = Inverted(**_fields("inverted"))
'''


@pytest.fixture
def user_folder(tmp_path, monkeypatch):
    return user_module(tmp_path, monkeypatch, "user_tasks", USER_MODULE)


def test_the_built_in_tasks_keep_the_contract():
    for task in (NAVIGATION, BLOCK_REACH):
        assert check_contract(task, task.name) is task


def test_a_task_written_with_lists_is_read_as_numbers(user_folder):
    task = get_task("user_tasks:AS_LISTS")
    assert all(isinstance(getattr(task, m), np.ndarray) for m in ("goal_low", "goal_high", "layouts"))
    assert task.sample_goals(np.random.default_rng(0)).shape == (2, 2)


def test_a_task_of_your_own_is_found_by_module_and_object_and_then_by_name(user_folder):
    task = get_task("user_tasks:GOOD")
    assert task.name == "my_rover" and get_task("my_rover") is task and get_task("user_tasks:GOOD") is task
    assert tasks.task_reference(task) == "user_tasks:GOOD" and tasks.task_reference(NAVIGATION) == "navigation"
    assert tasks.find_task("my_rover") is task and tasks.find_task("nobody") is None
    assert get_task("user_tasks:make_good").name == "my_rover_2"  # a factory of no arguments


@pytest.mark.parametrize("reference, message", [
    ("user_tasks:MISSING", "user_tasks:MISSING: reach_used: is required and not defined"),
    ("user_tasks:WRONG_SHAPE", "user_tasks:WRONG_SHAPE: task_space: must map a state (3,) to a point (2,), got (3,)"),
    ("user_tasks:BAD_LAYOUTS", "layouts: must have shape (6, 2, 2), got (5, 2, 2)"),
    ("user_tasks:BAD_BOX", "workspace_low: the workspace [-0.5, -2.5]..[4.0, 2.5] must hold the goal box"),
    ("user_tasks:BAD_NAME", "name: must be lower case letters"),
    ("user_tasks:BAD_LABELS", "ambiguous_layouts: must be a tuple of some (not all) of the layout numbers"),
    ("user_tasks:CLOSE_LAYOUT", "user_tasks:CLOSE_LAYOUT: layouts: layout 3: goals 0 and 1 are 0.020 m apart (minimum"),
    ("user_tasks:START_LAYOUT", "user_tasks:START_LAYOUT: layouts: layout 5: goal 1 is 0.050 m from the start (minimum"),
    ("user_tasks:WORDS", "user_tasks:WORDS: goal_low: must be numbers, got list"),
    ("user_tasks:SHORT_STATE", "user_tasks:SHORT_STATE: state: the environment's state must have shape (3,), got (2,)"),
    ("user_tasks:NAN_BOUND", "user_tasks:NAN_BOUND: state_bounds: y (coordinate 1) has bounds"),
    ("user_tasks:INVERTED", "user_tasks:INVERTED: state_bounds: heading (coordinate 2) has low 230.3 >= high -230.3"),
    ("user_tasks:NOT_A_TASK", "user_tasks:NOT_A_TASK is a int, not a scdp.tasks.Task"),
    ("user_tasks:NOBODY", "'user_tasks' has no 'NOBODY'"),
    ("no_such_module:TASK", "cannot import 'no_such_module'"),
    ("rover", "unknown task 'rover'"),
])
def test_a_task_that_breaks_its_contract_is_refused_in_one_line_at_load(user_folder, capsys, reference, message):
    refused_at_load(reference, message, user_folder, capsys)


def test_an_installed_entry_point_is_found_by_its_name(user_folder, monkeypatch):
    """A distribution on the path declaring ``[scdp.tasks] rover = user_tasks:GOOD`` (as ``pip install``
    of a package with that entry point leaves it) makes ``--task rover`` work; its task must pass too."""
    site = user_folder / "site"
    info = site / "user_robot-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: user-robot\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text("[scdp.tasks]\nrover = user_tasks:GOOD\nbroken = user_tasks:BAD_BOX\n")
    monkeypatch.syspath_prepend(str(site))
    assert get_task("rover").name == "my_rover"
    with pytest.raises(ScdpError, match="broken: workspace_low: the workspace"):
        get_task("broken")
    with pytest.raises(ScdpError, match="installed: broken, rover"):
        get_task("rover_2")


def test_a_task_may_not_take_a_built_in_name_or_another_task_s(user_folder):
    (user_folder / "clash.py").write_text("from dataclasses import replace\nfrom scdp.tasks import NAVIGATION\n"
                                          "SAME = replace(NAVIGATION)\nTWIN = replace(NAVIGATION, name='my_rover')\n")
    with pytest.raises(ScdpError, match="a built-in task's name"):
        get_task("clash:SAME")
    get_task("user_tasks:GOOD")
    with pytest.raises(ScdpError, match="as user_tasks:GOOD is; task names must differ"):
        get_task("clash:TWIN")


def test_fixed_layouts_takes_2d_points_with_a_height_or_3d_points():
    from scdp.tasks.base import fixed_layouts

    flat = [[(1.0, 0.2 * k), (1.0, -0.2 * k - 0.1)] for k in range(6)]
    assert fixed_layouts(flat).shape == (6, 2, 2) and fixed_layouts(flat, z=0.3)[..., 2].tolist() == [[0.3, 0.3]] * 6
    lifted = [[(x, y, 0.1 * k) for x, y in pair] for k, pair in enumerate(flat)]
    assert np.array_equal(fixed_layouts(lifted)[..., 2], np.repeat(0.1 * np.arange(6)[:, None], 2, axis=1))
    with pytest.raises(ScdpError, match="layouts: expected six pairs"):
        fixed_layouts(flat[:5])
