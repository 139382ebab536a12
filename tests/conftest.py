import numpy as np
import pytest

from scdp.tasks import BLOCK_REACH, NAVIGATION


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
    """`scdp reproduce --task all --preset tiny` run once for the session; its output folder."""
    from scdp.cli import main

    out = tmp_path_factory.mktemp("tiny") / "run"
    assert main(["reproduce", "--task", "all", "--preset", "tiny", "--out", str(out)]) == 0
    return out
