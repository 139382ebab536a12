"""The layering rules of the house, checked on the source itself.

Layers, bottom up: robots, envs, tasks, data, scoring, models, policies, training, evaluation,
pipeline, serve, cli. The leaves (errors, io, keys, metrics, ambiguity, drawing, sections, config, presets) import
only other leaves, and any layer may use them. A module imports only from its own layer or
below, every import statement sits at module top, and no import cycle exists, counting
imports anywhere in a module (inside functions too).
"""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).parents[1] / "src"
LEAVES = {"scdp.errors", "scdp.messages", "scdp.io", "scdp.keys", "scdp.metrics", "scdp.ambiguity", "scdp.drawing", "scdp.config", "scdp.config.shapes", "scdp.config.preset", "scdp.config.planning", "scdp.presets", "scdp.sections", "scdp.threads", "scdp.devices"}
LAYERS = ["robots", "envs", "tasks", "perception", "execution", "data", "scoring", "models", "policies", "training", "evaluation", "deploy", "pipeline", "serve", "cli"]
MAX_LINES = 400


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def layer(module: str) -> int:
    if module in LEAVES:
        return -1
    if module in ("scdp", "scdp.__main__"):
        return len(LAYERS)
    top = module.split(".")[1]
    return LAYERS.index(top)


def imports(module: str) -> list[tuple[str, int, bool]]:
    """(imported scdp module, line, at module top) for every import statement of ``module``."""
    tree = ast.parse(MODULES[module].read_text())
    top_level = {id(node) for node in tree.body}
    found = []
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in MODULES else node.module for a in node.names]
        for name in names:
            if name.split(".")[0] == "scdp":
                found.append((name, node.lineno, id(node) in top_level))
            elif id(node) not in top_level:
                found.append((name, node.lineno, False))
    return found


def test_every_module_is_assigned_a_layer():
    for module in MODULES:
        layer(module)  # raises ValueError for a top-level module outside the layers and leaves


def test_imports_sit_at_module_top():
    late = [f"{m}:{line} imports {name}" for m in MODULES for name, line, top in imports(m) if not top]
    assert not late, late


def test_imports_only_go_down_the_layers():
    wrong = []
    for m in MODULES:
        for name, line, _ in imports(m):
            if name in MODULES and name != "scdp" and layer(name) > layer(m):
                wrong.append(f"{m}:{line} ({layer(m)}) imports {name} ({layer(name)})")
    assert not wrong, wrong


def test_no_import_cycle():
    graph = {m: {name for name, _, _ in imports(m) if name in MODULES and name != m} for m in MODULES}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for n in graph[m]:
            if state.get(n) == 1:
                raise AssertionError(" -> ".join(stack[stack.index(n):] + [n]))
            if n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in graph:
        if m not in state:
            visit(m)


@pytest.mark.parametrize("cycle", [{"scdp.a": {"scdp.b"}, "scdp.b": {"scdp.a"}}])
def test_the_cycle_check_can_fail(cycle, monkeypatch):
    """The detector above does find a cycle when one exists."""
    monkeypatch.setitem(globals(), "MODULES", {m: None for m in cycle})
    monkeypatch.setitem(globals(), "imports", lambda m: [(n, 1, True) for n in cycle[m]])
    with pytest.raises(AssertionError, match="scdp.a -> scdp.b -> scdp.a|scdp.b -> scdp.a -> scdp.b"):
        test_no_import_cycle()


def test_no_source_file_is_too_long():
    long = {m: n for m, p in MODULES.items() if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, long
