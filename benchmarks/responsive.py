"""How responsive scdp is as a user and a robot meet it: a command's wall time, a service's answers.

Regenerates: `results/benchmarks/responsive.md`

    python benchmarks/responsive.py --run results/cpu --out results/benchmarks/responsive

On one machine, alone (it times things), Navigation on the run's committed checkpoints:

1. **The machine**: its float32 matmul rate, and ``python -c "import torch, numpy"`` as a whole
   process (the yardstick every other time is divided by).
2. **``scdp plan``** with its defaults, as a whole process (median of ``--repeats``), and split into
   import, load, plan and score by the same steps run in one process.
3. **``scdp serve``**: seconds from the process start to its first ``/v1/health`` answer, then
   ``/v1/act`` and ``/v1/plan`` p50 and p95 as the client sees them and as the server reports them
   (``server_ms``), over one kept-alive httpx client and with ``Connection: close``.

Writes ``OUT.json`` and ``OUT.md``; every time also as a ratio to the torch import.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
import numpy as np
import torch
from serve_load import act_bodies, free_port, wait_until_up

from scdp import threads
from scdp.config import PlanningOptions
from scdp.data.bezier import demo_path
from scdp.io import write_json, write_text
from scdp.policies.exported import OnnxDenoiser
from scdp.scoring import DEFAULT_REFERENCES, reference_bounds
from scdp.scoring.score import raw_scores
from scdp.serve.app import PlanningService, PlanRequest
from scdp.tasks import get_task

GOALS = ["2.0,0.2", "2.0,-0.2"]
SPLIT = """
import json, sys, time
t0 = time.perf_counter()
import scdp.cli.plan
from scdp.cli import main
t1 = time.perf_counter()
main(sys.argv[1:])
seconds = json.loads(open(sys.argv[sys.argv.index("--out") + 1]).read())["seconds"]
print(json.dumps({"import": t1 - t0, "load": seconds["loading"], "plan": seconds["rollout"], "score": seconds["scoring"]}))
"""


def wall(cmd: list[str], repeats: int) -> list[float]:
    """Seconds of ``cmd`` as a whole process, ``repeats`` times."""
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        out.append(time.perf_counter() - t0)
    return out


def matmul_gflops(n: int = 1024, reps: int = 20) -> float:
    a, b = torch.randn(n, n), torch.randn(n, n)
    a @ b
    t0 = time.perf_counter()
    for _ in range(reps):
        a @ b
    return 2 * n**3 * reps / (time.perf_counter() - t0) / 1e9


def bounds_ms(scenes: int = 20) -> dict:
    """Milliseconds per scene of its reference bounds (100 generator paths, D and E of each): in one pass
    (scdp.scoring.reference_bounds), and path by path as before (demo_path and raw_scores in a loop)."""
    task = get_task("navigation")
    goal_sets = [task.sample_goals(np.random.default_rng(s), 2) for s in range(scenes)]
    t0 = time.perf_counter()
    for goals in goal_sets:
        reference_bounds(task, goals, 0)
    t1 = time.perf_counter()
    for goals in goal_sets:
        rng = np.random.default_rng(0)
        [raw_scores(task, demo_path(task, rng, task.start_point, goals[0])[0], goals, 0) for _ in range(DEFAULT_REFERENCES)]
    t2 = time.perf_counter()
    return {"one_pass": 1000 * (t1 - t0) / scenes, "path_by_path": 1000 * (t2 - t1) / scenes, "scenes": scenes}


def percentiles(values) -> dict:
    v = np.asarray(values, dtype=np.float64)
    return {"p50": float(np.percentile(v, 50)), "p95": float(np.percentile(v, 95)), "n": len(v)}


def calls(url: str, route: str, bodies: list[dict], keep_alive: bool, warm: dict) -> dict:
    """Client and server milliseconds of one request per body, back to back, after one ``warm`` request."""
    client_ms, server_ms = [], []
    headers = {} if keep_alive else {"Connection": "close"}
    with httpx.Client(timeout=120.0) as client:
        client.post(f"{url}{route}", json=warm, headers=headers).raise_for_status()
        for body in bodies:
            t0 = time.perf_counter()
            r = client.post(f"{url}{route}", json=body, headers=headers)
            client_ms.append(1000 * (time.perf_counter() - t0))
            r.raise_for_status()
            server_ms.append(float(r.json()["server_ms"]))
    return {"client_ms": percentiles(client_ms), "server_ms": percentiles(server_ms),
            "gap_p50_ms": float(np.median(np.subtract(client_ms, server_ms)))}


def service(checkpoints: Path, act: int, plans: int, method: str = "scdp", flags: list[str] = ()) -> dict:
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "scdp", "serve", "--task", "navigation", "--checkpoints",
                             str(checkpoints), "--port", str(port), "--methods", method, *flags],
                            stdout=subprocess.DEVNULL)  # the timed planner only: a flag it takes may not suit another
    try:
        wait_until_up(url, proc, poll_s=0.02)
        first = time.perf_counter() - t0
        task = get_task("navigation")
        bodies = act_bodies(task, max(act, plans) + 1, 0, method)  # the last one only warms
        plan_bodies = [{k: b[k] for k in ("goals", "target", "method", "seed")} for b in bodies]
        out = {"first_answer_s": first}
        # scenes the service has not scored yet (their reference bounds computed), then the same scenes
        # again (bounds memoised, as for a client that replans a scene), over each connection kind
        out["plan_new_keep_alive"] = calls(url, "/v1/plan", plan_bodies[:plans], True, warm=plan_bodies[-1])
        for name, keep in (("keep_alive", True), ("close", False)):
            out[f"act_{name}"] = calls(url, "/v1/act", bodies[:act], keep, warm=bodies[-1])
            out[f"plan_{name}"] = calls(url, "/v1/plan", plan_bodies[:plans], keep, warm=plan_bodies[-1])
        return out
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def denoiser_floor(checkpoints: Path, plans: int, method: str = "scdp", runtime: str | None = None,
                   warm_skip: int | None = None) -> dict:
    """``/v1/plan``'s work in this process, on the service's own object and the benchmark's scenes
    (their bounds memoised by a first pass): per scene, the milliseconds of the whole trajectory and of
    its ONNX denoiser calls alone, and how many calls; the part of ``server_ms`` no Python change reaches."""
    planning = PlanningOptions.of_entry("serve", runtime=runtime, warm_skip=warm_skip)
    service = PlanningService(checkpoints, "navigation", methods=(method,), planning=planning)
    threads.use_for_planning(service.meta.get("parameters", 0))  # as the service's planner thread
    bodies = act_bodies(get_task("navigation"), plans + 1, 0, method)
    requests = [PlanRequest(**{k: b[k] for k in ("goals", "target", "method", "seed")}) for b in bodies[:plans]]
    timed = {"calls": 0, "s": 0.0}
    forward = OnnxDenoiser.forward

    def counted(self, *args, **kwargs):
        t0 = time.perf_counter()
        out = forward(self, *args, **kwargs)
        timed["s"] += time.perf_counter() - t0
        timed["calls"] += 1
        return out

    for request in requests:  # first pass: bounds memoised, ONNX Runtime's buffers allocated
        service.plan_scene(request, service.check_request(request)[1])
    whole, network, calls = [], [], []
    OnnxDenoiser.forward = counted
    try:
        for request in requests:
            goals = service.check_request(request)[1]
            timed.update(calls=0, s=0.0)
            t0 = time.perf_counter()
            service.plan_scene(request, goals)
            whole.append(1000 * (time.perf_counter() - t0))
            network.append(1000 * timed["s"])
            calls.append(timed["calls"])
    finally:
        OnnxDenoiser.forward = forward
    return {"plan_p50_ms": float(np.median(whole)), "denoiser_p50_ms": float(np.median(network)),
            "calls_p50": float(np.median(calls)), "ms_per_call": float(sum(network) / sum(calls)),
            "denoiser_share": float(sum(network) / sum(whole))}


def report(r: dict, command: str) -> str:
    base = r["import_torch_s"]
    s = r["service"]
    lines = [f"# Responsiveness: a command, a service (`{r.get('method', 'scdp')}`)", "",
             f"`{command}` (Navigation, committed cpu checkpoints, alone on the machine; {r['minutes']:.1f} min). "
             f"Machine: {r['gflops']:.0f} GFLOP/s float32 matmul (1024²), {r['cores']} cores; "
             f"`python -c \"import torch, numpy\"` takes **{base:.2f} s** as a whole process (median of "
             f"{r['repeats']}): every ratio below is to it.", "",
             "## `scdp plan` (defaults)", "",
             "| part | seconds | × import torch |", "|---|---|---|",
             f"| the whole command (median) | {r['plan_wall_s']:.2f} | {r['plan_wall_s'] / base:.2f} |"]
    for k, v in r["plan_split_s"].items():
        lines.append(f"| {k} | {v:.3f} | {v / base:.2f} |")
    lines += ["", "The split runs the same command in one process and reads the seconds it records (import = "
              "`scdp.cli.plan` and what it loads; load = the checkpoints; plan = one trajectory; score = its reference "
              "bounds and metrics); the rest is the whole command's median less those medians.", "",
              f"A new scene's reference bounds (100 generator paths, D and E of each; mean of {r['bounds_ms']['scenes']} "
              f"Navigation scenes): {r['bounds_ms']['one_pass']:.1f} ms in one pass, {r['bounds_ms']['path_by_path']:.1f} ms "
              "path by path (the loop scoring ran before issue 61; the same values).", "",
              "## `scdp serve`", "",
              f"First `/v1/health` answer {s['first_answer_s']:.2f} s after the process starts "
              f"({s['first_answer_s'] / base:.2f} × import torch).", "",
              "| route | connection | client p50 ms | client p95 ms | server p50 ms | server p95 ms | client − server, p50 ms |",
              "|---|---|---|---|---|---|---|"]
    rows = [("act", "keep_alive", "kept alive"), ("act", "close", "`Connection: close`"),
            ("plan", "new_keep_alive", "kept alive, scenes new to the service"),
            ("plan", "keep_alive", "kept alive, the same scenes again"), ("plan", "close", "`Connection: close`, the same scenes again")]
    for route, conn, label in rows:
        c = s[f"{route}_{conn}"]
        lines.append(f"| `/v1/{route}` | {label} | {c['client_ms']['p50']:.1f} | {c['client_ms']['p95']:.1f} | "
                     f"{c['server_ms']['p50']:.1f} | {c['server_ms']['p95']:.1f} | {c['gap_p50_ms']:.1f} |")
    f = r["denoiser_floor"]
    lines += ["", "A scene new to the service has its reference bounds computed for scoring (then memoised, "
              "`BOUNDS_MEMO` scenes); the same scene again reads them back.", "",
              "**What `/v1/plan` is made of** (the same scenes again, planned in this process on the service's own "
              f"object): {f['plan_p50_ms']:.1f} ms p50 per trajectory, of which its ONNX denoiser calls alone take "
              f"{f['denoiser_p50_ms']:.1f} ms p50 ({f['calls_p50']:.0f} calls p50, {f['ms_per_call']:.2f} ms each; "
              f"{100 * f['denoiser_share']:.0f} % of all planning time). The rest is the scene encoder, the style "
              "predictors, the arbitration, the simulator's steps and their checks."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", type=Path, default=Path("results/cpu"), help="a reproduction whose navigation/checkpoints to use")
    p.add_argument("--repeats", type=int, default=5, help="whole-process timings per command (median reported)")
    p.add_argument("--act", type=int, default=60, help="/v1/act calls per connection kind")
    p.add_argument("--plans", type=int, default=20, help="/v1/plan calls per connection kind")
    p.add_argument("--method", default="scdp", help="the planner timed (default scdp; scdp_student: the few-step student)")
    p.add_argument("--runtime", choices=["torch", "onnx", "auto"], help="passed to plan and serve (default: their profile's)")
    p.add_argument("--warm-skip", type=int, help="passed to plan and serve (default: their profile's; 6: round 3's candidate)")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/responsive"))
    args = p.parse_args(argv)
    flags = (["--runtime", args.runtime] if args.runtime else []) + (["--warm-skip", str(args.warm_skip)]
                                                                      if args.warm_skip is not None else [])
    command = " ".join(["python", "benchmarks/responsive.py", *(argv if argv is not None else sys.argv[1:])])
    checkpoints = args.run / "navigation" / "checkpoints"
    start = time.perf_counter()
    base = statistics.median(wall([sys.executable, "-c", "import torch, numpy"], args.repeats))
    with tempfile.TemporaryDirectory() as tmp:
        plan_cmd = [sys.executable, "-m", "scdp", "plan", "--task", "navigation", "--checkpoints", str(checkpoints),
                    "--goals", *GOALS, "--method", args.method, *flags, "--out", str(Path(tmp) / "plan.json"), "--force"]
        plan_wall = statistics.median(wall(plan_cmd, args.repeats))
        splits = [json.loads(subprocess.run([sys.executable, "-c", SPLIT, *plan_cmd[3:]], check=True, capture_output=True,
                                            text=True).stdout.strip().splitlines()[-1]) for _ in range(args.repeats)]
    split = {k: statistics.median(s[k] for s in splits) for k in splits[0]}
    split["interpreter and the rest"] = plan_wall - sum(split.values())
    result = {"command": command, "import_torch_s": base, "plan_wall_s": plan_wall, "plan_split_s": split,
              "gflops": matmul_gflops(), "cores": torch.get_num_threads(), "repeats": args.repeats, "bounds_ms": bounds_ms(),
              "method": args.method, "service": service(checkpoints, args.act, args.plans, args.method, flags),
              "denoiser_floor": denoiser_floor(checkpoints, args.plans, args.method, args.runtime, args.warm_skip)}
    result["minutes"] = (time.perf_counter() - start) / 60
    write_json(args.out.with_suffix(".json"), result)
    write_text(args.out.with_suffix(".md"), report(result, command))
    print(report(result, command))
    return 0


if __name__ == "__main__":
    sys.exit(main())
