"""results/SEEDS.md, the ledger of scene seeds: no (stream, seed) serves two choices or two
confirmations (the one reuse it marks aside), and the protocols that pick seeds use ledger rows."""

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
