"""Independent units on Ray (scdp.pipeline.executor): the same records as the local executor, and a
worker killed mid-run costs only the stage it was making."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import sys
import threading
from pathlib import Path

import pytest
import ray

from scdp.cli import main
from scdp.errors import ScdpError
from scdp.io import held
from scdp.pipeline.executor import LocalExecutor, Unit, make_executor

TIMING = ("seconds", "wall", "executor", "minutes", "command", "time")  # keys that say when or how, not what
# the tiny preset with the paper's three methods only: every stage and the report, in seconds
SMALL = ["--task", "navigation", "--preset", "tiny", "--set", 'evaluation.methods=["dp","ld","scdp"]']


def _what(value):
    """A record without its timings and without the run folder's own name in its paths."""
    if isinstance(value, dict):
        return {k: _what(v) for k, v in value.items() if not any(t in k for t in TIMING)}
    if isinstance(value, list):
        return [_what(v) for v in value]
    return value.split("/", 1)[-1] if isinstance(value, str) and value.startswith("run_") else value


def _records(out: Path) -> dict:
    """Every JSON record and every weight file of a run, by its path in the run."""
    found = {str(p.relative_to(out)): _what(json.loads(p.read_text())) for p in out.rglob("*.json")}
    found |= {str(p.relative_to(out)): sorted(json.loads(p.read_text())) for p in out.rglob("stage_times.json")}  # which stages
    found |= {str(p.relative_to(out)): p.read_bytes() for p in out.rglob("model.safetensors")}
    return found


def _square(x, *, report):
    report(1)
    return x * x


def test_the_local_executor_runs_each_unit_in_order():
    units = [Unit(f"u{x}", _square, (x,), cpus=1) for x in (3, 4, 5)]
    assert LocalExecutor().run(units) == [9, 16, 25]
    assert make_executor("local").describe().startswith("local executor, 1 worker")
    with pytest.raises(ScdpError, match="--executor: --ray-address and --workers are for --executor ray"):
        make_executor("local", workers=2)
    with pytest.raises(ScdpError, match="unknown executor 'slurm'"):
        make_executor("slurm")


def test_the_ray_executor_without_ray_names_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # as where scdp[cluster] is not installed
    assert main(["reproduce", "--preset", "tiny", "--task", "navigation", "--out", str(tmp_path / "r"), "--executor", "ray"]) == 2
    assert capsys.readouterr().err.strip() == "scdp: error: --executor: ray needs Ray, which is not installed: pip install 'scdp[cluster]'"
    assert not (tmp_path / "r").exists()  # refused before anything is written


def _hold(path, ready, release):
    with held(path):
        ready.set()
        release.wait()


def test_a_stage_lock_held_by_one_process_refuses_another_and_dies_with_its_holder(tmp_path):
    lock = tmp_path / ".locks" / "base.lock"
    ctx = multiprocessing.get_context("spawn")
    ready, release = ctx.Event(), ctx.Event()
    holder = ctx.Process(target=_hold, args=(lock, ready, release))
    holder.start()
    try:
        assert ready.wait(60)
        with pytest.raises(ScdpError, match=rf"held by pid {holder.pid} on "):
            with held(lock, wait=False):
                pass
    finally:
        os.kill(holder.pid, signal.SIGKILL)  # killed, not released: the system lets go of its lock
        holder.join()
    with held(lock, wait=False):  # no stale lock left behind
        assert lock.read_text().startswith(f"pid {os.getpid()} ")


def _worker_running(title: str) -> int | None:
    """The pid of the Ray worker whose process title is ``ray::<title>`` (the task's name)."""
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if (entry / "cmdline").read_bytes().split(b"\0")[0].decode() == f"ray::{title}":
                    return int(entry.name)
            except OSError:
                continue
    return None


@pytest.mark.slow  # about 50 s: the full suite (CI) runs it, the quick loop does not
def test_ray_reproduces_two_seeds_as_the_local_executor_does_and_resumes_after_a_killed_worker(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["--threads", "1", "reproduce", *SMALL, "--seeds", "1", "--out", "run_local"]) == 0  # the killed seed's

    # The killer: once seed 1's base is recorded (its stage finished), kill the worker making seed 1's
    # model set (its later stages not yet made). Ray runs the unit again on another worker.
    folder = Path("run_ray/seed_1/navigation")
    finished = {"base weights": folder / "checkpoints/base/model.safetensors", "base record": folder / "checkpoints/base/inputs.json",
                "demos": folder / "demos.zarr", "demos record": folder / "demos.inputs.json",
                "base seconds": folder / ".stages/base.seconds"}  # the last thing a finished stage writes
    seen, stop = {}, threading.Event()

    def kill_when_base_is_written():
        while not stop.is_set():
            if finished["base seconds"].exists() and (pid := _worker_running("seed_1 navigation models")):
                seen.update({name: path.stat() for name, path in finished.items()})
                os.kill(pid, signal.SIGKILL)
                seen["killed"] = pid
                return
            stop.wait(0.01)

    killer = threading.Thread(target=kill_when_base_is_written, daemon=True)
    killer.start()
    try:
        assert main(["--threads", "1", "reproduce", *SMALL, "--seeds", "0", "1", "--out", "run_ray", "--executor", "ray",
                     "--workers", "2"]) == 0
        with pytest.raises(ScdpError, match=r"--threads: a unit computes with 3 thread\(s\).* the largest Ray node has 2 CPU"):
            make_executor("ray").run([Unit("wide", _square, (2,), cpus=3)])  # refused, not left waiting for ever
    finally:
        stop.set()
        killer.join()
        ray.shutdown()
    out = capsys.readouterr().out
    assert "killed" in seen, "the worker making seed 1's model set finished before it could be killed"
    # the stages it had finished were not made again: the same files, untouched
    for name, path in finished.items():
        now = path.stat()
        assert (now.st_ino, now.st_mtime_ns) == (seen[name].st_ino, seen[name].st_mtime_ns), name
    local, remote = _records(tmp_path / "run_local" / "seed_1"), _records(tmp_path / "run_ray" / "seed_1")
    assert set(local) == set(remote) and len(local) > 15
    assert {k for k in local if local[k] != remote[k]} == set()
    summary = json.loads((tmp_path / "run_ray" / "seed_0" / "summary.json").read_text())
    assert summary["executor"].startswith("Ray executor, 2 worker CPU(s) on 1 node(s), 1 thread(s) per unit")
    assert "Run by the Ray executor, 2 worker CPU(s)" in (tmp_path / "run_ray" / "seed_1" / "report.md").read_text()
    assert "done in" in out


def test_seeds_are_refused_beside_a_seed_and_into_a_folder_of_other_files(tmp_path, capsys):
    assert main(["reproduce", "--preset", "tiny", "--seed", "1", "--seeds", "0", "1", "--out", str(tmp_path / "a")]) == 2
    assert "--seeds: not allowed with argument --seed" in capsys.readouterr().err
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "notes.txt").write_text("mine")
    assert main(["reproduce", "--preset", "tiny", "--seeds", "0", "--out", str(tmp_path / "b")]) == 2
    assert "b holds files that are not seed_K folders" in capsys.readouterr().err
    assert main(["reproduce", "--preset", "tiny", "--seeds", "0", "0", "--out", str(tmp_path / "c")]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()  # nothing written
