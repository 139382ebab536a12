"""Crash safety and determinism of `scdp reproduce`, and results that recompute from what they store.

Every run here is a separate process with the same command and the same environment (the same
number of threads, which ``tests/conftest.py`` pins and a subprocess inherits: float reductions,
and so the last digits, depend on it), sharing nothing but the disk. The reference is one
uninterrupted run: the session's tiny reproduction (``--task all``, in the test process that built
it), whose Navigation records a ``--task navigation`` run repeats exactly. (``SCDP_TINY_RUN`` must
then name a run made with the suite's thread count: 1 under ``-n 2``, else 2.)
"""

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from scdp.evaluation.records import METRIC_KEYS, load_records, rescore
from scdp.io import write_json
from scdp.presets import PRESETS
from scdp.tasks import get_task

COMMAND = ["reproduce", "--task", "navigation", "--preset", "tiny"]
# SIGKILL as each of these stage lines is printed: training, the style stage, LD and the evaluation,
# spread over the stages of one reproduction (each re-run resumes the one before). The kill follows
# the line, not a delay, so where it lands does not depend on the machine's speed.
KILL_AFTER = ("[navigation] stage base", "[navigation] stage style_efficient", "[navigation] stage ld",
              "[navigation] stage evaluate")
TINY = PRESETS["tiny"].evaluation
# records of one task: every method and the Dataset row, on both random sets and every layout's targets
RECORDS = (len(TINY.methods) + 1) * (2 * TINY.scenes + 6 * 2 * TINY.layout_repeats)


def scored(out) -> dict:
    """(task, scene set, method, scene index) -> (success, metrics) of a run's random-protocol records."""
    data = json.loads((out / "results.json").read_text())
    return {(t["task"], t["scene_set"], t["method"], t["scene_index"]): (t["success"], t["metrics"])
            for t in data["trajectories"] if t.get("protocol") in (None, "random")}


def scdp_process(out, **kw) -> subprocess.Popen:
    """``scdp`` in its own process; the caller waits with a timeout."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}  # the suite's thread count, as the reference was made
    return subprocess.Popen([sys.executable, "-m", "scdp", *COMMAND, "--out", str(out)], env=env, text=True, **kw)


def quiet_run(out) -> int:
    return scdp_process(out, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).wait(timeout=600)


@pytest.fixture(scope="module")
def reference(tiny_reproduction):
    return {key: value for key, value in scored(tiny_reproduction).items() if key[0] == "navigation"}


def test_reproduce_killed_at_any_stage_resumes_to_identical_results(reference, tmp_path):
    """Five processes (four killed, one finishing) give exactly the records of another, uninterrupted
    run: the run is deterministic across processes and resumes exactly. (A separate uninterrupted
    rerun was dropped for CI time: any difference between two processes fails here too.)"""
    assert len(reference) == RECORDS
    out = tmp_path / "killed"
    for marker in KILL_AFTER:
        proc = scdp_process(out, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
        for line in proc.stdout:
            if line.startswith(marker):
                proc.send_signal(signal.SIGKILL)
                break
        proc.stdout.close()
        assert proc.wait(timeout=60) == -signal.SIGKILL, f"the run ended before {marker!r}"
        assert not (out / "results.json").exists()  # the report is the last thing written
    assert quiet_run(out) == 0
    assert scored(out) == reference


def test_every_stored_metric_recomputes_from_its_stored_path(tiny_reproduction):
    records = [r for r in load_records(tiny_reproduction / "results.json") if r.protocol in (None, "random")]
    assert len(records) == 2 * RECORDS  # both tasks
    worst = 0.0
    for r in records:
        again = rescore(get_task(r.task), r)
        worst = max(worst, max(abs(again[k] - r.metrics[k]) for k in METRIC_KEYS))
        assert np.allclose(r.path, np.round(r.path, 4), rtol=0, atol=1e-12)  # stored exactly as scored: 0.1 mm
    assert worst <= 1e-6


def test_gzip_records_read_back_as_written_and_bytes_repeat(tiny_reproduction, tmp_path):
    records = load_records(tiny_reproduction / "results.json")
    rows = {"trajectories": [r.to_dict() for r in records]}
    first, second = write_json(tmp_path / "a.json.gz", rows, compact=True), write_json(tmp_path / "b.json.gz", rows, compact=True)
    assert first.read_bytes()[:2] == b"\x1f\x8b" and first.read_bytes() == second.read_bytes()  # gzip, no time stamp
    assert [r.to_dict() for r in load_records(first)] == rows["trajectories"]
