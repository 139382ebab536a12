"""The mutations the test suite must catch: each applied to the source in turn and shown caught.

    python benchmarks/mutations.py              # every mutation (about 10 min on 2 cores)
    python benchmarks/mutations.py --only warm  # one, by name

Regenerates: `results/benchmarks/mutations.md`

A mutation replaces one snippet of ``src/`` (it must occur there exactly once) with a broken
version, runs the tests that must catch it, and puts the file back whatever happens. It is caught
when pytest exits 1 with at least one failed test (not a collection or usage error). The tests
run as the suite runs them, from nothing: a test that needs a trained run trains it under the
mutation (``SCDP_TINY_RUN``/``SCDP_CI_RUN`` are dropped from the environment). docs/tests.md
lists the same mutations and why each matters; the suite without any mutation passes (``.ci/run``).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "results" / "benchmarks" / "mutations.md"


@dataclass(frozen=True)
class Mutation:
    name: str
    what: str  # the broken behaviour, in words
    file: str  # under src/scdp
    old: str
    new: str
    tests: tuple[str, ...]  # pytest node ids or files that must fail


MUTATIONS = (
    Mutation("gradients", "gradient averaging deleted: each data-parallel process steps with its own slice's gradient",
             "training/loop.py",
             'p.grad = accelerator.reduce(p.grad if p.grad is not None else torch.zeros_like(p), reduction="mean")',
             "pass",
             ("tests/test_accelerate.py::test_two_processes_step_with_the_gradient_of_the_whole_batch",)),
    Mutation("films", "the films not applied: the U-Net's residual blocks ignore the style's (γ, β)",
             "models/unet1d.py",
             "            h = gamma * h + beta\n", "            h = h\n",
             ("tests/test_behaviour.py", "tests/test_style_predictor.py", "tests/test_unet1d.py")),
    Mutation("arbitration", "the arbitration always legible: SCDP's auto style plans every chunk legible",
             "policies/scdp.py",
             "return ARBITRATION_RULES[self.arbitration](positions, goals, target, self.task.ambiguity).astype(np.float64)",
             "return np.ones(len(target))",
             ("tests/test_behaviour.py", "tests/test_adaptivity.py")),
    Mutation("warm", "the warm start ignored: a chunk said to start warm is sampled from pure noise",
             "policies/diffusion.py",
             'return {"init": self.warm_init(warm, state_hist), "warm": rows}, starts',
             "return {}, starts",
             ("tests/test_warm_start.py",)),
    Mutation("content-key", "the content key missing a field: a style predictor's record leaves out its training schedule",
             "training/recipe.py",
             'recipe = {"model": section.model.to_dict(), "train": section.train.to_dict(),',
             'recipe = {"model": section.model.to_dict(),',
             ("tests/test_fingerprints.py::test_one_changed_section_field_retrains_exactly_its_parts", "tests/test_recipe.py")),
    Mutation("study-length", "the study serving a path's length: a trial's first answer carries its point count",
             "study/design.py",
             '"colours": [{"name": PALETTE[c][0], "hex": PALETTE[c][1]} for c in trial.colours], "view": view}',
             '"colours": [{"name": PALETTE[c][0], "hex": PALETTE[c][1]} for c in trial.colours], "view": view,\n'
             '            "points": len(stim.path)}',
             ("tests/test_study_server.py", "tests/test_study_rules.py")),
    Mutation("service-finite", "the service answering a non-finite state: /v1/act and /v1/plan take NaN and inf states",
             "serve/app.py",
             'hist = self.task.check_states(states, "state_history")',
             "hist = np.asarray(states, dtype=np.float64)",
             ("tests/test_serve_guards.py", "tests/test_serve.py")),
)


def run_mutation(m: Mutation) -> dict:
    path = REPO / "src" / "scdp" / m.file
    original = path.read_text()
    if original.count(m.old) != 1:
        raise SystemExit(f"mutations: error: {m.name}: the snippet occurs {original.count(m.old)} times in src/scdp/{m.file}, not once")
    env = {k: v for k, v in os.environ.items() if k not in ("SCDP_TINY_RUN", "SCDP_CI_RUN")}
    start = time.perf_counter()
    try:
        path.write_text(original.replace(m.old, m.new))
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rf", "-n", "2", *m.tests],
                              cwd=REPO, env=env, capture_output=True, text=True)
    finally:
        path.write_text(original)
    failed = sorted(set(re.findall(r"^FAILED (\S+)", proc.stdout, flags=re.M)))
    summary = (proc.stdout.strip().splitlines() or ["(no output)"])[-1]
    return {"caught": proc.returncode == 1 and bool(failed), "failed": failed, "summary": summary,
            "minutes": (time.perf_counter() - start) / 60}


def report(rows: list[tuple[Mutation, dict]]) -> str:
    lines = ["# Mutations the suite must catch", "",
             "Made by `python benchmarks/mutations.py`: each mutation is applied to `src/scdp/`, the tests named run "
             "from nothing (pytest-xdist, 2 processes), and the file is put back. docs/tests.md says why each matters.", "",
             "| mutation | what breaks | file | tests run | caught | failing tests | pytest's last line | minutes |",
             "|---|---|---|---|---|---|---|---|"]
    for m, r in rows:
        failing = "<br>".join(f"`{f.split('::', 1)[-1]}`" for f in r["failed"]) or "none"
        tests = "<br>".join(f"`{t.removeprefix('tests/')}`" for t in m.tests)
        lines.append(f"| {m.name} | {m.what} | `{m.file}` | {tests} | {'yes' if r['caught'] else '**NO**'} | {failing} | "
                     f"{r['summary'].strip('= ')} | {r['minutes']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", nargs="+", choices=[m.name for m in MUTATIONS], help="these mutations alone (prints, writes nothing)")
    args = parser.parse_args(argv)
    chosen = [m for m in MUTATIONS if not args.only or m.name in args.only]
    rows = []
    for m in chosen:
        print(f"[mutation] {m.name}: {m.what} ... ", end="", flush=True)
        rows.append((m, run_mutation(m)))
        print("caught" if rows[-1][1]["caught"] else "NOT CAUGHT", f"({rows[-1][1]['summary']})", flush=True)
    text = report(rows)
    if args.only:
        print(text)
    else:
        tmp = OUT.with_suffix(".md.tmp")
        tmp.write_text(text)
        tmp.replace(OUT)
        print(f"wrote {OUT.relative_to(REPO)}")
    return 0 if all(r["caught"] for _, r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
