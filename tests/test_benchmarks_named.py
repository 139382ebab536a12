"""Every script in ``benchmarks/`` names, in a ``Regenerates:`` line of its header, the committed
``results/`` files it makes, and each of them exists: a script that regenerates nothing committed
belongs in ``benchmarks/archive/``, and a result renamed or removed fails here naming the script."""

import re
from pathlib import Path

ROOT = Path(__file__).parents[1]
HEADER_LINES = 40  # the Regenerates line sits in a script's header: its docstring or first comments
NAMED = re.compile(r"`([^`]+)`")


def regenerates(text: str) -> list[str] | None:
    """The paths a script's header names after ``Regenerates:`` (None: no such line)."""
    for line in text.splitlines()[:HEADER_LINES]:
        _, found, rest = line.partition("Regenerates:")
        if found:
            return NAMED.findall(rest)
    return None


def missing(root: Path, scripts: list[Path]) -> dict[str, str]:
    """Script name -> what is wrong: no Regenerates line, or a named path (a glob, or a folder ending
    in /) that matches no file under ``root``."""
    wrong = {}
    for script in scripts:
        named = regenerates(script.read_text())
        if not named:
            wrong[script.name] = "names no committed result (no Regenerates: line)"
            continue
        for path in named:
            matches = [p for p in (root / path).rglob("*") if p.is_file()] if path.endswith("/") else \
                [p for p in root.glob(path) if p.is_file()]
            if not path.startswith("results/") or not matches:
                wrong[script.name] = f"{path} is not a committed result"
    return wrong


def benchmark_scripts() -> list[Path]:
    return sorted(p for p in (ROOT / "benchmarks").iterdir() if p.suffix in (".py", ".sh"))


def test_every_benchmark_names_the_results_it_regenerates_and_they_exist():
    assert len(benchmark_scripts()) > 20  # the folder is found
    assert missing(ROOT, benchmark_scripts()) == {}


def test_the_benchmark_results_check_can_fail(tmp_path):
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "speed.md").write_text("a table")
    scripts = {"good.py": '"""Speed.\n\nRegenerates: `results/speed.md`\n"""\n',
               "gone.py": '"""Speed.\n\nRegenerates: `results/speed.md`, `results/renamed.md`\n"""\n',
               "orphan.sh": "#!/usr/bin/env bash\n# A probe that writes nothing committed.\n"}
    for name, text in scripts.items():
        (tmp_path / name).write_text(text)
    assert missing(tmp_path, [tmp_path / n for n in sorted(scripts)]) == {
        "gone.py": "results/renamed.md is not a committed result",
        "orphan.sh": "names no committed result (no Regenerates: line)"}
