"""Shared fixtures. Threads are pinned first: float reductions, and so the last digits of every
trained weight and metric, depend on the number of threads, and determinism tests compare runs.

The README's test command runs the suite in two processes (pytest-xdist, ``-n 2``), one core each;
a run that trains (the tiny and ci presets) is built once for the whole test run by the first
process that asks for it, while any other waits on a file lock and then reads the same folder
(:func:`built_once`)."""

import os
import shutil
from collections.abc import Callable
from pathlib import Path

# the CI machine's 2 cores: both for one process, one each for pytest-xdist's two; subprocesses inherit it
XDIST_WORKER = os.environ.get("PYTEST_XDIST_WORKER")  # this process's name under pytest-xdist (gw0, gw1), else None
TEST_THREADS = 1 if XDIST_WORKER else 2
os.environ["OMP_NUM_THREADS"] = os.environ["MKL_NUM_THREADS"] = str(TEST_THREADS)

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402
from filelock import FileLock  # noqa: E402

from scdp.tasks import BLOCK_REACH, NAVIGATION  # noqa: E402

torch.set_num_threads(TEST_THREADS)


@pytest.fixture(params=[NAVIGATION, BLOCK_REACH], ids=lambda t: t.name)
def task(request):
    return request.param


@pytest.fixture(scope="session")
def small_datasets():
    """A few generated demos per task, shared across tests (seconds to build)."""
    from scdp.data.generate import generate_demos

    return {t.name: generate_demos(t, 12, seed=3, progress=False)[0] for t in (NAVIGATION, BLOCK_REACH)}


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def built_once(tmp_path_factory, name: str, build: Callable[[Path], None]) -> Path:
    """``OUT/name``, made by ``build(OUT/name)`` once for the whole test run. Under pytest-xdist OUT is
    the run's folder, shared by its processes: the first to ask builds under a file lock, the others
    wait on it and reuse the folder. A build that failed part-way is started again from nothing."""
    root = tmp_path_factory.getbasetemp()
    if XDIST_WORKER:
        root = root.parent  # pytest-of-USER/pytest-N, above each process's own popen-gwK
    out, done = root / "built" / name, root / "built" / f"{name}.done"
    out.parent.mkdir(parents=True, exist_ok=True)
    with FileLock(str(root / "built" / f"{name}.lock")):
        if not done.exists():
            shutil.rmtree(out, ignore_errors=True)
            build(out)
            done.touch()
    return out


def _reproduce(*args: str) -> Callable[[Path], None]:
    from scdp.cli import main

    def build(out: Path) -> None:
        assert main(["reproduce", *args, "--out", str(out)]) == 0
    return build


@pytest.fixture(scope="session")
def tiny_reproduction(tmp_path_factory):
    """`scdp reproduce --task all --preset tiny`, run once for the test run; a copy of its output folder
    that is this process's own (so no test can change another's). ``SCDP_TINY_RUN`` names a finished
    tiny run to reuse instead."""
    reuse = os.environ.get("SCDP_TINY_RUN")
    built = Path(reuse) if reuse else built_once(tmp_path_factory, "tiny", _reproduce("--task", "all", "--preset", "tiny"))
    return Path(shutil.copytree(built, tmp_path_factory.mktemp("tiny") / "run"))


@pytest.fixture(scope="session")
def exported_tiny(tiny_reproduction, tmp_path_factory):
    """The tiny run's checkpoints of both tasks, copied and exported (``scdp export``): ``OUT/<task>``.
    Tests read it and must not change it."""
    from scdp.cli import main

    def build(out: Path) -> None:
        for task in ("navigation", "block_reach"):
            shutil.copytree(tiny_reproduction / task / "checkpoints", out / task)
            assert main(["export", "--task", task, str(out / task)]) == 0
    return built_once(tmp_path_factory, "exported", build)


@pytest.fixture(scope="session")
def competent_navigation(tmp_path_factory):
    """`scdp reproduce --task navigation --preset ci` run once for the test run: a small model set that
    works (tests/test_behaviour.py); its output folder, which tests read and must not change.
    ``SCDP_CI_RUN`` names a finished run to reuse."""
    reuse = os.environ.get("SCDP_CI_RUN")
    if reuse:
        return Path(reuse)
    return built_once(tmp_path_factory, "ci", _reproduce("--task", "navigation", "--preset", "ci"))


# Session fixtures that train (minutes on 2 cores): a test that needs one is slow, and the quick loop
# (`python3 -m pytest -q -n 2 -m "not slow"`, README) leaves it out; `.ci/run` runs everything.
TRAINED_FIXTURES = {"tiny_reproduction", "exported_tiny", "competent_navigation"}
SLOW_MODULES = {"test_crash_safety.py", "test_accelerate.py", "test_goals_end_to_end.py", "test_example_task.py",  # pipelines
                "test_study_page.py"}  # a real browser
SLOW_TESTS = {"test_the_committed_tables_claims_and_report_recompute_from_results_json"}  # re-scores every committed run


NO_GPU = f"needs a CUDA GPU: torch {torch.__version__} sees none here (benchmarks/gpu.sh runs these where one is)"


def pytest_collection_modifyitems(config, items):
    for item in items:
        if item.get_closest_marker("gpu") and not torch.cuda.is_available():
            item.add_marker(pytest.mark.skip(reason=NO_GPU))
        if (TRAINED_FIXTURES & set(getattr(item, "fixturenames", ())) or item.path.name in SLOW_MODULES
                or getattr(item, "originalname", item.name) in SLOW_TESTS):
            item.add_marker(pytest.mark.slow)
    items[:] = longest_first(items)


def longest_first(items: list) -> list:
    """Whole files, the longest kinds first: the file that trains the ci preset (minutes), then files with
    any slow test, then the rest, each group in collection order. Under ``-n 2 --dist loadfile
    --no-loadscope-reorder`` (pyproject.toml) one process starts on the ci preset while the other builds
    the tiny run and takes what reads it, and the short files left at the end even out the two
    processes' finishing times. A file's tests stay together, so module fixtures are built once."""
    def kind(item) -> int:
        if "competent_navigation" in getattr(item, "fixturenames", ()):
            return 0
        return 1 if item.get_closest_marker("slow") else 2

    files: dict = {}
    for item in items:
        files.setdefault(item.path, []).append(item)
    ordered = sorted(files.values(), key=lambda group: min(kind(i) for i in group))  # stable: collection order within
    return [item for group in ordered for item in group]


from helpers.tiny import TINY  # noqa: E402
from scdp.training import parts  # noqa: E402


@pytest.fixture(scope="session")
def tiny_ckpt(tmp_path_factory, small_datasets):
    """Tiny checkpoints of every part for Navigation (seconds)."""
    root = tmp_path_factory.mktemp("ckpt")
    ds = small_datasets["navigation"]
    parts.train_diffusion(NAVIGATION, ds, TINY, root / "base", progress=False)
    parts.train_diffusion(NAVIGATION, ds, TINY, root / "ld", ld=True, progress=False, base_dir=root / "base")
    parts.train_encoder(NAVIGATION, TINY, root / "encoder", progress=False)
    for style in ("legible", "efficient"):
        parts.train_style(NAVIGATION, ds, style, TINY, root / "base", root / "encoder", root / f"style_{style}",
                          progress=False, references=20)
    return root
