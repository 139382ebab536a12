"""Functions short enough to read (issue 78): none in ``src/scdp`` over 100 lines, and the list of those over 60
only shrinks. A function that grows past 60 lines fails here; one on the list that shrinks under 60 must leave
it (so the list stays the truth), and none may grow. The page's script is under the same 400-line rule as a
module."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).parents[1] / "src" / "scdp"
LONG, TOO_LONG, MAX_FILE_LINES = 60, 100, 400
# qualified name -> its length when this list was made; shorten them, then take them off
KNOWN_LONG = {
    "robots/panda.py:mjcf": 83, "evaluation/rollout.py:rollout": 75, "pipeline/run.py:reproduce": 75,
    "study/screening.py:participant_table": 69, "pipeline/report.py:report_markdown": 67, "study/app.py:create_app":
    67, "deploy/scene.py:deploy_scene": 66,
}


def function_lengths(root: Path) -> dict[str, int]:
    """``file:function`` -> lines, for every function (methods and nested ones too) under ``root``."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                key = f"{path.relative_to(root).as_posix()}:{node.name}"
                out[key] = max(out.get(key, 0), node.end_lineno - node.lineno + 1)
    return out


def over_the_limits(lengths: dict[str, int], known: dict[str, int]) -> list[str]:
    """What breaks the rule: a function over 100 lines, a new one over 60, a known one grown, a known one fixed."""
    wrong = [f"{k}: {n} lines, over {TOO_LONG}" for k, n in lengths.items() if n > TOO_LONG]
    wrong += [f"{k}: {n} lines, over {LONG} and not on the list" for k, n in lengths.items() if n > LONG and k not in known]
    wrong += [f"{k}: grew from {known[k]} to {n} lines" for k, n in lengths.items() if k in known and n > known[k]]
    wrong += [f"{k}: now {lengths.get(k, 0)} lines, take it off the list" for k in known if lengths.get(k, 0) <= LONG]
    return wrong


def test_functions_stay_short_and_the_long_list_only_shrinks():
    assert over_the_limits(function_lengths(SRC), KNOWN_LONG) == []
    assert len(KNOWN_LONG) < 8  # 16 over 60 lines at 75ead46; the issue asks for fewer than 8


@pytest.mark.parametrize("lengths, words", [({"a.py:f": 101}, "over 100"), ({"a.py:g": 61}, "not on the list"),
                                            ({"a.py:h": 70}, "grew from 65"), ({"a.py:h": 50}, "take it off")])
def test_the_length_rule_can_fail(lengths, words):
    assert any(words in w for w in over_the_limits(lengths, {"a.py:h": 65} if "h" in next(iter(lengths)) else {}))


def test_the_study_pages_scripts_are_under_the_module_line_rule():
    scripts = sorted((SRC / "study").glob("*.js"))
    assert len(scripts) >= 2 and all(len(p.read_text().splitlines()) <= MAX_FILE_LINES for p in scripts)
