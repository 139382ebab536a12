"""Shared fixtures. Threads are pinned first: float reductions, and so the last digits of every
trained weight and metric, depend on the number of threads, and determinism tests compare runs."""

import os
import shutil
from pathlib import Path

TEST_THREADS = 2  # the CI machine's cores; subprocesses inherit it through the environment
os.environ["OMP_NUM_THREADS"] = os.environ["MKL_NUM_THREADS"] = str(TEST_THREADS)

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

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


@pytest.fixture(scope="session")
def tiny_reproduction(tmp_path_factory):
    """`scdp reproduce --task all --preset tiny` run once for the session; its output folder.
    ``SCDP_TINY_RUN`` names a finished tiny run to reuse (copied, so no test can change it)."""
    from scdp.cli import main

    out = tmp_path_factory.mktemp("tiny") / "run"
    reuse = os.environ.get("SCDP_TINY_RUN")
    if reuse:
        return Path(shutil.copytree(reuse, out))
    assert main(["reproduce", "--task", "all", "--preset", "tiny", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="session")
def exported_tiny(tiny_reproduction, tmp_path_factory):
    """The tiny run's checkpoints of both tasks, copied and exported (``scdp export``): ``OUT/<task>``.
    Tests read it and must not change it."""
    from scdp.cli import main

    out = tmp_path_factory.mktemp("exported")
    for task in ("navigation", "block_reach"):
        shutil.copytree(tiny_reproduction / task / "checkpoints", out / task)
        assert main(["export", "--task", task, str(out / task)]) == 0
    return out


@pytest.fixture(scope="session")
def competent_navigation(tmp_path_factory):
    """`scdp reproduce --task navigation --preset ci` run once for the session: a small model set that
    works (tests/test_behaviour.py); its output folder. ``SCDP_CI_RUN`` names a finished run to reuse."""
    from scdp.cli import main

    reuse = os.environ.get("SCDP_CI_RUN")
    if reuse:
        return Path(reuse)
    out = tmp_path_factory.mktemp("ci") / "run"
    assert main(["reproduce", "--task", "navigation", "--preset", "ci", "--out", str(out)]) == 0
    return out


# Session fixtures that train (minutes on 2 cores): a test that needs one is slow, and the quick loop
# (`python3 -m pytest -q -m "not slow"`, README) leaves it out; `.ci/run` runs everything.
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
