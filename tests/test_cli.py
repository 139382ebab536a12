import json
import subprocess
import sys

import numpy as np
import pytest

from helpers.floats import mismatches
from scdp.cli import main
from scdp.data.dataset import DemoDataset
from scdp.tasks import get_task


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_help_lists_every_command(capsys):
    code, out, _ = run(capsys)
    for name in ("generate", "inspect", "plot-demos", "import-hdf5", "ambiguity-report", "plot-ellipse", "reproduce"):
        assert name in out
    assert code != 0  # no command given


def test_generate_inspect_plot(tmp_path, capsys):
    out = tmp_path / "d.zarr"
    code, text, _ = run(capsys, "generate", "--task", "navigation", "--num-demos", "4", "--seed", "2", "--out", str(out))
    assert code == 0 and out.exists() and "4 demos" in text
    code, text, _ = run(capsys, "inspect", str(out))
    assert code == 0 and '"episodes": 4' in text
    code, _, _ = run(capsys, "plot-demos", str(out), "--out", str(tmp_path / "d.png"))
    assert code == 0 and (tmp_path / "d.png").stat().st_size > 1000


BAD = [
    (["generate", "--task", "navigation", "--num-demos", "-3", "--seed", "0"], "--num-demos"),
    (["generate", "--task", "unicycle", "--num-demos", "3", "--seed", "0"], "task"),
    (["generate", "--task", "navigation", "--num-demos", "3", "--seed", "abc"], "--seed"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,nan", "2,-0.2"], "goals"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,inf", "2,-0.2"], "goals"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,0.2"], "goals"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,0.2", "2,0.2"], "goals"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,0.2", "2,0.25"], "goals"),
    (["plot-ellipse", "--task", "navigation", "--goals", "2,0.2", "2,-0.2", "--target", "2"], "target"),
    (["plot-ellipse", "--task", "navigation", "--goals", "9,0.2", "2,-0.2"], "goals"),
    (["plot-ellipse", "--task", "block_reach", "--goals", "0.85,0.5", "0.5,-0.2"], "goals[0]"),
    (["plot-ellipse", "--task", "navigation", "--goals", "0.1,0.05", "2,-0.2"], "goals"),  # at the start
    (["reproduce", "--preset", "tiny", "--protocol", "per_layout", "--layouts", "0", "7"], "--layouts"),
    (["reproduce", "--preset", "tiny", "--protocol", "sometimes"], "--protocol"),
]


@pytest.mark.parametrize("argv, field", BAD, ids=[f"{a[0]}-{f}-{i}" for i, (a, f) in enumerate(BAD)])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, argv, field):
    out = tmp_path / ("o.zarr" if argv[0] == "generate" else "o.png")
    code, _, err = run(capsys, *argv, "--out", str(out))
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"scdp: error: {field}:"), err
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_existing_output_needs_force_and_survives(tmp_path, capsys):
    out = tmp_path / "d.zarr"
    assert run(capsys, "generate", "--task", "navigation", "--num-demos", "2", "--seed", "0", "--out", str(out))[0] == 0
    before = sorted(p.name for p in out.rglob("*"))
    code, _, err = run(capsys, "generate", "--task", "navigation", "--num-demos", "3", "--seed", "0", "--out", str(out))
    assert code == 2 and "already exists" in err
    assert sorted(p.name for p in out.rglob("*")) == before


def test_unwritable_output(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    code, _, err = run(capsys, "generate", "--task", "navigation", "--num-demos", "2", "--seed", "0",
                       "--out", str(blocker / "sub" / "d.zarr"))
    assert code == 2 and err.startswith("scdp: error: --out: cannot write")


def test_console_script_exit_status(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "scdp", "inspect", str(tmp_path / "missing.zarr")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"scdp: error: dataset: {tmp_path / 'missing.zarr'} does not exist"


def test_import_hdf5_cli(tmp_path, capsys, small_datasets):
    import h5py

    ep = small_datasets["navigation"].episode(0)
    with h5py.File(tmp_path / "d.hdf5", "w") as f:
        f["data/demo_0/states"] = ep["state"]
        f["data/demo_0/actions"] = ep["action"]
        f["data/demo_0/obs/object"] = np.repeat(ep["goals"].reshape(1, -1), len(ep["state"]), 0)
    code, text, _ = run(capsys, "import-hdf5", str(tmp_path / "d.hdf5"), "--task", "navigation", "--out", str(tmp_path / "d.zarr"))
    assert code == 0 and "1 demos" in text


def _stage_outputs(out):
    """Modification times of the random-scene protocol's stage outputs."""
    names = ["demos.zarr", "ambiguity.json", "trajectories.json"] + [f"checkpoints/{p}/model.safetensors" for p in
                                                                    ("base", "ld", "encoder", "style_legible", "style_efficient")]
    return {(task, n): (out / task / n).stat().st_mtime_ns for task in ("navigation", "block_reach") for n in names}


EVERY_METHOD = ("dp", "ld", "ld_paper", "scdp", "scdp_paper", "scdp_blend", "scdp_legible", "scdp_efficient", "dataset")


def test_reproduce_tiny_runs_and_resumes(tiny_reproduction, capsys):
    """`scdp reproduce` end to end on the tiny preset: every output file and the results schema."""
    out = tiny_reproduction
    for task in ("navigation", "block_reach"):
        for name in ("demos.zarr", "demos.png", "ambiguity.json", "ambiguity.md", "ellipse.png", "trajectories.json"):
            assert (out / task / name).exists(), name
        for part in ("base", "ld", "encoder", "style_legible", "style_efficient"):
            meta = json.loads((out / task / "checkpoints" / part / "config.json").read_text())
            assert meta["complete"] and meta["task"] == task and meta["preset"] == "tiny"
    for name in ("results.json", "table1.md", "table1.tex", "table2.md", "table2.tex", "figure2.png", "figure2.pdf",
                 "report.md", "claims.json", "summary.json"):
        assert (out / name).stat().st_size > 0, name

    results = json.loads((out / "results.json").read_text())
    assert results["preset"] == "tiny" and results["command"].startswith("scdp reproduce")
    assert results["overrides"] == []
    trajs = results["trajectories"]
    sets = {"ambiguous", "non_ambiguous"} | {f"layout_{i}" for i in range(1, 7)}
    # tiny (the cpu preset's methods): 2 random scenes per set + 6 layouts x 2 targets, for 9 methods and 2 tasks
    assert len(trajs) == 2 * len(EVERY_METHOD) * (2 + 2 + 12)
    for t in trajs:
        assert t["task"] in ("navigation", "block_reach") and t["scene_set"] in sets
        assert t["method"] in EVERY_METHOD
        assert isinstance(t["success"], bool) and 0.0 <= t["j_hat"] <= 1.0 and t["seconds"] >= 0
        assert set(t["bounds"]) == {"d_min", "d_max", "e_min", "e_max"}
        assert set(t["metrics"]) == {"detachment", "efficiency", "d_hat", "e_hat", "transparency", "legibility"}
        assert len(t["path"]) >= 2 and len(t["path"][0]) == (3 if t["task"] == "block_reach" else 2)
        assert len(t["goals"]) == 2 and t["target"] in (0, 1)
        if t["method"] in ("scdp", "scdp_paper", "scdp_blend"):
            assert t["styles"] and set(t["styles"]) <= {"legible", "efficient"}
        if t["method"] in ("scdp_legible", "scdp_efficient"):  # a forced style plans every chunk in it
            assert set(t["styles"]) == {t["method"][5:]}
    for task in ("navigation", "block_reach"):
        for s in sets:
            assert {t["method"] for t in trajs if t["task"] == task and t["scene_set"] == s} == set(EVERY_METHOD)
    table1 = (out / "table1.md").read_text()
    assert "0.52 ± 0.06" in table1 and "Ours (SCDP)" in table1  # the paper's numbers beside ours
    assert r"\begin{tabular}" in (out / "table1.tex").read_text()
    judged = json.loads((out / "claims.json").read_text())
    claims, paired = judged["claims"], judged["paired_differences"]
    # the paper's claims (5 rows) and the success claim again on the layout groups, per task
    assert len(claims) == 2 * 6 and all(isinstance(c["holds"], bool) for c in claims)
    beats = [c for c in claims if c["claim"] == "SCDP beats DP in ambiguous scenes (T_fa)"]
    assert len(beats) == 2 and all(c["holds"] == (c["numbers"]["paired_difference"][1] > 0) for c in beats)
    # the 7 pairs (scdp − dp, ld, ld_paper, scdp_paper, dataset; scdp_blend − dp; scdp_legible − scdp_efficient)
    # on T, T_fa, d_hat, e_hat, per task and random scene set (2 scenes each in tiny), and on T, T_fa per
    # layout group (3 layouts x 2 targets, one repeat: 6 scenes)
    random_rows = [p for p in paired if p["scene_set"] in ("ambiguous", "non_ambiguous")]
    assert len(random_rows) == 2 * 2 * 7 * 4 and all(p["n"] == 2 for p in random_rows)
    assert len(paired) - len(random_rows) == 2 * 2 * 7 * 2
    assert all(p["n"] == p["scenes"] and p["lo"] <= p["mean"] <= p["hi"] for p in paired)
    assert judged["metric_sensitivity"]["ranges"]["navigation"]["source"] == "training dataset"
    report = (out / "report.md").read_text()
    assert "claims" in report and "Paired differences" in report and "## Metric sensitivity" in report

    written = _stage_outputs(out)
    code, text, _ = run(capsys, "reproduce", "--task", "all", "--preset", "tiny", "--out", str(out))
    assert code == 0 and _stage_outputs(out) == written  # every stage was up to date: nothing rewritten
    code, _, err = run(capsys, "reproduce", "--preset", "huge", "--out", str(out))
    assert code == 2 and "--preset" in err

    # The authors' per-layout protocol beside it: the random-scene stages are reused.
    code, text, _ = run(capsys, "reproduce", "--task", "all", "--preset", "tiny", "--protocol", "both", "--layouts", "1", "4",
                        "--out", str(out))
    assert code == 0 and _stage_outputs(out) == written  # the random-scene stages were reused
    for task in ("navigation", "block_reach"):
        for k in (1, 4):
            folder = out / task / "per_layout" / f"layout_{k}"
            assert not (out / task / "per_layout" / "layout_2").exists()
            demos = DemoDataset.load(folder / "demos.zarr")
            assert demos.num_episodes == 4 and np.allclose(demos.goals, get_task(task).layouts[k - 1])
            for part in ("base", "ld", "style_legible", "style_efficient"):
                meta = json.loads((folder / "checkpoints" / part / "config.json").read_text())
                assert meta["complete"] and meta["task"] == task
    results = json.loads((out / "results.json").read_text())
    assert results["protocols"] == ["random", "per_layout"]
    assert set(results["compute_minutes"]) >= {"per_layout", "random"}  # each protocol's compute is recorded
    per_layout = [t for t in results["trajectories"] if t["protocol"] == "per_layout"]
    assert len(results["trajectories"]) - len(per_layout) == len(trajs)
    assert len(per_layout) == 2 * len(EVERY_METHOD) * 2 * 2  # tasks x methods x layouts x targets
    assert {t["scene_set"] for t in per_layout} == {"layout_1", "layout_4"}
    for name in ("table3.md", "table3.tex", "figure2_per_layout.png", "figure2_per_layout.pdf"):
        assert (out / name).stat().st_size > 0, name
    assert "per-layout models" in (out / "table3.md").read_text()
    claims = json.loads((out / "claims.json").read_text())["claims"]
    assert sorted({c["protocol"] for c in claims}) == ["per_layout", "random"] and len(claims) == 2 * (6 + 5)
    assert "per-layout protocol" in (out / "report.md").read_text()


def test_threads_option_sets_the_pool_and_keeps_a_users_wait_policy(capsys, monkeypatch):
    import torch

    from scdp import threads

    before = torch.get_num_threads()
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # set, so that monkeypatch restores what configure changes
        monkeypatch.setenv(name, "7")
        monkeypatch.delenv(name)
    try:
        threads.configure(1)
        assert torch.get_num_threads() == 1 and __import__("os").environ["OMP_NUM_THREADS"] == "1"
        assert __import__("os").environ["OMP_WAIT_POLICY"] == "ACTIVE"  # the user's choice stands
    finally:
        torch.set_num_threads(before)
    code, _, err = run(capsys, "--threads", "0", "inspect", "nowhere.zarr")
    assert code == 2 and err.strip() == "scdp: error: --threads: must be >= 1, got 0"


def test_importing_scdp_defaults_to_sleeping_openmp_threads():
    env = {k: v for k, v in __import__("os").environ.items() if k != "OMP_WAIT_POLICY"}
    code = "import os, scdp; print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True, timeout=120).stdout
    assert out.strip() == "PASSIVE"


ARGUMENTS = [
    (["plot-ellipse", "--task", "navigation", "--goals", "2,0.2", "2,-0.2", "--out", "e.jpg"], "--out"),
    (["plot-demos", "missing.zarr", "--out", ""], "--out"),
    (["plan", "--task", "navigation", "--checkpoints", ".", "--goals", "2,0.2", "2,-0.2", "--seed", "-1", "--out", "p.json"], "--seed"),
    (["evaluate", "--task", "navigation", "--checkpoints", ".", "--seed", "-5"], "--seed"),
    (["generate", "--task", "navigation", "--num-demos", "100000000000", "--seed", "0", "--out", "d.zarr"], "--num-demos"),
    (["ambiguity-report", "--task", "navigation", "--scenes", "5000000"], "--scenes"),
]


@pytest.mark.parametrize("argv, field", ARGUMENTS, ids=[f"{a[0]}-{f}-{i}" for i, (a, f) in enumerate(ARGUMENTS)])
def test_bad_arguments_name_their_field(tmp_path, capsys, monkeypatch, argv, field):
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, *argv)
    assert code == 2 and err.strip().startswith(f"scdp: error: {field}:") and len(err.strip().splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


def test_every_image_and_report_writer_needs_force(tmp_path, capsys):
    out = tmp_path / "e.png"
    out.write_bytes(b"keep")
    argv = ["plot-ellipse", "--task", "navigation", "--goals", "2,0.2", "2,-0.2", "--out", str(out)]
    code, _, err = run(capsys, *argv)
    assert code == 2 and "--force" in err and out.read_bytes() == b"keep"
    code, _, _ = run(capsys, *argv, "--force")
    assert code == 0 and out.read_bytes() != b"keep"
    report = tmp_path / "r.json"
    report.with_suffix(".md").write_text("keep")
    code, _, err = run(capsys, "ambiguity-report", "--task", "navigation", "--scenes", "50", "--out", str(report))
    assert code == 2 and "r.md" in err and not report.exists()


def test_batch1_planning_uses_one_thread_for_small_nets_and_every_core_for_large_ones(monkeypatch):
    import torch

    from scdp import threads

    before = torch.get_num_threads()
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    monkeypatch.setattr(threads, "cores", lambda: 3)
    try:
        assert threads.use_for_planning(1_133_635) == 1 == torch.get_num_threads()  # the cpu preset's U-Net
        assert threads.use_for_planning(threads.LARGE_NETWORK) == 3 == torch.get_num_threads()
        monkeypatch.setenv("OMP_NUM_THREADS", "2")  # the user's count wins at any size
        assert threads.use_for_planning(threads.LARGE_NETWORK) == 2 and threads.use_for_planning(10) == 2
    finally:
        torch.set_num_threads(before)


def test_report_rebuilds_the_report_files_from_results_json_and_keeps_existing_ones(tiny_reproduction, tmp_path, capsys):
    results, out = tiny_reproduction / "results.json", tmp_path / "rebuilt"
    assert main(["report", str(results), "--out", str(out), "--no-figures"]) == 0
    rebuilt, original = (json.loads((d / "claims.json").read_text()) for d in (out, tiny_reproduction))
    # nothing rerun (SCDP_TINY_RUN may name a run made on another processor: float rounding allowed)
    assert not mismatches(rebuilt["observers"], original["observers"]) and rebuilt["observers"]["path_length"]["summary"]["tasks"]
    assert rebuilt["observers"]["demonstration"]["summary"]["tasks"] and rebuilt["observers"]["temperatures"]
    assert "## What an observer reads" in (out / "report.md").read_text()
    assert "### Viewpoint observer" in (out / "report.md").read_text()
    # adaptivity: every planner that ran, both scene sets, D̂ and each observer's accuracy, Ê and path length
    shares = {(r["planner"], r["scene_set"], r["measure"]) for r in rebuilt["adaptivity"]}
    for measure in ("d_hat", "path_length_correct_at_50", "demonstration_correct_at_50", "viewpoint_correct_at_50"):
        assert ("scdp", "ambiguous", measure) in shares and ("ld", "ambiguous", measure) in shares
    assert {("scdp", "non_ambiguous", m) for m in ("e_hat", "path_length")} <= shares
    assert "## Adaptivity, measured directly" in (out / "report.md").read_text()
    assert not (out / "observer_accuracy.png").exists() and (tiny_reproduction / "observer_accuracy.png").exists()
    capsys.readouterr()
    (out / "report.md").write_text("keep")
    assert main(["report", str(results), "--out", str(out)]) == 2  # report.md exists: --force needed
    assert "already exists" in capsys.readouterr().err and (out / "report.md").read_text() == "keep"
    assert main(["report", str(tmp_path / "missing.json")]) == 2
    assert capsys.readouterr().err.startswith("scdp: error: results: ")
    # the observer's threshold is a flag; a looser one makes no run less confident
    loose = tmp_path / "loose"
    assert main(["report", str(results), "--out", str(loose), "--no-figures", "--confidence", "0.6"]) == 0
    for observer in ("path_length", "demonstration"):
        observed = json.loads((loose / "claims.json").read_text())["observers"][observer]["summary"]
        assert observed["threshold"] == 0.6 and rebuilt["observers"][observer]["summary"]["threshold"] == 0.8
        for task, sets in observed["tasks"].items():
            for scene_set, methods in sets.items():
                for method, m in methods.items():
                    strict = rebuilt["observers"][observer]["summary"]["tasks"][task][scene_set][method]
                    assert m["never_confident"] <= strict["never_confident"] and m["capped"] <= strict["capped"]
    for bad, field in [("[]", "results"), ('{"trajectories": []}', "results"), ("not json", "results")]:
        (tmp_path / "bad.json").write_text(bad)
        assert main(["report", str(tmp_path / "bad.json"), "--out", str(tmp_path / "never")]) == 2
        assert capsys.readouterr().err.startswith(f"scdp: error: {field}: ") and not (tmp_path / "never").exists()
    assert main(["report", str(results), "--out", str(tmp_path / "never"), "--confidence", "1.5"]) == 2
    assert "--confidence" in capsys.readouterr().err
