"""results/SEEDS.md, the ledger of scene seeds: no (stream, seed) serves two choices or two
confirmations (the one reuse it marks aside), and the protocols that pick seeds use ledger rows."""

import json
import re
from pathlib import Path

ROOT = Path(__file__).parents[1]


def ledger(text: str) -> list[dict]:
    rows = []
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[1].isdigit():
            rows.append(dict(zip(("stream", "seed", "purpose", "kind", "where"), cells)))
    return rows


def reused(rows: list[dict]) -> list[tuple]:
    """(stream, seed) pairs that serve more than one choice, or more than one confirmation, unmarked."""
    seen, out = {}, []
    for r in rows:
        kind = r["kind"].split(" ")[0]
        if kind not in ("choice", "confirmation") or "(reused)" in r["kind"]:
            continue
        key = (r["stream"], r["seed"], kind)
        if key in seen:
            out.append(key)
        seen[key] = r
    return out


def test_no_seed_serves_two_choices_or_two_confirmations():
    rows = ledger((ROOT / "results" / "SEEDS.md").read_text())
    assert len(rows) >= 10
    assert not reused(rows)
    planted = rows + [{"stream": "validation", "seed": "59", "purpose": "a new choice", "kind": "choice", "where": "-"}]
    assert reused(planted) == [("validation", "59", "choice")]  # the check catches a reuse


def test_the_round_two_gate_and_the_normalisation_confirmation_use_their_ledger_rows():
    rows = {(r["stream"], r["seed"]): r for r in ledger((ROOT / "results" / "SEEDS.md").read_text())}
    gate = (ROOT / "benchmarks" / "realtime_gate2.py").read_text()
    assert re.search(r"^SEED, SCENES = (\d+),", gate, re.M).group(1) == "59" and ("validation", "59") in rows
    confirm = (ROOT / "benchmarks" / "confirm_normalisation.sh").read_text()
    assert re.search(r"^SCENES=(\d+)$", confirm, re.M).group(1) == "59" and ("evaluation", "59") in rows


def seeds_used(root: Path) -> dict[tuple[str, str], list[str]]:
    """Every (stream, scene seed) a JSON record under ``root`` says it used: a top level naming ``stream`` and
    ``seed``, or an ``evaluation_seed``; {(stream, seed): [files]}. The archive is history, not results."""
    out: dict = {}
    for path in sorted(root.rglob("*.json")):
        if "archive" in path.relative_to(root).parts:
            continue
        try:
            record = json.loads(path.read_text())
        except ValueError:
            continue
        if not isinstance(record, dict):
            continue
        pairs = [(record["stream"], record["seed"])] if "stream" in record and "seed" in record else []
        pairs += [("evaluation", record["evaluation_seed"])] if "evaluation_seed" in record else []
        for stream, seed in pairs:
            out.setdefault((str(stream), str(seed)), []).append(str(path.relative_to(root)))
    return out


def test_every_scene_seed_results_use_is_in_the_ledger(tmp_path):
    rows = {(r["stream"], r["seed"]) for r in ledger((ROOT / "results" / "SEEDS.md").read_text())}
    used = seeds_used(ROOT / "results")
    assert ("evaluation", "83") in used and ("validation", "2") in used  # the changing scenes, the LD sweep
    missing = {k: v for k, v in used.items() if k not in rows}
    assert not missing, f"scene seeds used under results/ without a row in results/SEEDS.md: {missing}"
    (tmp_path / "new.json").write_text(json.dumps({"stream": "evaluation", "seed": 4242}))
    assert ("evaluation", "4242") in seeds_used(tmp_path)  # a new run's seed is seen, and would be missing
