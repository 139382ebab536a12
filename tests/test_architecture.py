"""The layering rules of the house, checked on the source itself.

The floor plan (the layers bottom up, and the leaves) is written once, in the docstring of
``scdp/__init__.py``, and read from there. A module imports only from its own layer or below (the
leaves from other leaves only), every import statement sits at module top, and no import cycle
exists, counting imports anywhere in a module (inside functions too). Every ``task`` parameter is
annotated: ``Task`` from the tasks layer up, a Protocol in a leaf or below tasks.
"""

import ast
import re
from pathlib import Path

import pytest

SRC = Path(__file__).parents[1] / "src"


def floor_plan() -> tuple[list[str], set[str]]:
    """(layers bottom up, leaves) as ``scdp/__init__.py``'s docstring lists them."""
    doc = ast.get_docstring(ast.parse((SRC / "scdp" / "__init__.py").read_text()))
    layers_block = doc.split("bottom up", 1)[1].split("\n\n", 2)[1]
    leaves_block = doc.split("They are:", 1)[1].split("\n\n", 2)[1]
    layers = [re.match(r"\s+(\w+)\s", line).group(1) for line in layers_block.splitlines()]
    return layers, set(leaves_block.split())


LAYERS, LEAF_NAMES = floor_plan()
MAX_LINES = 400


def module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(SRC.rglob("*.py"))}


def layer(module: str) -> int:
    """-1 for a leaf, the layer's index, or one above every layer for the package and ``__main__``."""
    if module.split(".")[1:2] and module.split(".")[1] in LEAF_NAMES:
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


# where a module is imported by name (importlib), as the floor plan lists them
IMPORTED_BY_NAME = {"scdp.cli", "scdp.tasks", "scdp.perception.gl", "scdp.policies.diffusion", "scdp.pipeline.executor"}


def imports_by_name(module: str) -> bool:
    tree = ast.parse(MODULES[module].read_text())
    return any(isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", None))
               in ("import_module", "__import__") for node in ast.walk(tree))


def test_modules_are_imported_by_name_only_where_the_floor_plan_says():
    assert {m for m in MODULES if imports_by_name(m)} == IMPORTED_BY_NAME


# module constants whose name two modules use for different things (the value or its meaning differs)
SAME_NAME_OTHER_MEANING = {
    "CONFIDENCE": "an observer's belief threshold / the study's confidence scale",
    "FORMAT": "the made-from record's format / the study record's format",
    "FORMAT_VERSION": "a checkpoint's format / a dataset's format",
    "KINDS": "the study's trial kinds / interpolation kinds",
    "LABELS": "detector labels / the study report's labels",
    "MAX_BODY_BYTES": "the planning service's body cap (4 MiB) / the study's (16 KiB)",
    "MIN_SPAN": "a fitted normaliser range / a scene's D or E span",
    "NAMES": "GL backend names / normalisation names",
    "READ": "how each observer target reads a result / how the gate reads one",
    "SETS": "the evaluation's scene sets / the study's stimulus sets",
}


def module_constants(module: str) -> set[str]:
    tree = ast.parse(MODULES[module].read_text())
    return {t.id for node in tree.body if isinstance(node, ast.Assign) for t in node.targets
            if isinstance(t, ast.Name) and t.id.isupper() and len(t.id) > 1}


def test_a_constant_is_defined_in_one_module():
    """A threshold or name given twice drifts (MIN_SUCCESS was 5 definitions, two values): import it
    from its one home instead; the names above mean different things where they recur."""
    homes: dict[str, list[str]] = {}
    for module in MODULES:
        for name in module_constants(module):
            homes.setdefault(name, []).append(module)
    twice = {name: sorted(ms) for name, ms in homes.items() if len(ms) > 1 and name not in SAME_NAME_OTHER_MEANING}
    assert not twice, twice


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


def test_the_floor_plan_names_every_package_and_nothing_else():
    """Each top-level module or package of scdp is a layer or a leaf of the floor plan, and each
    name the plan lists exists (a renamed package cannot leave the plan stale)."""
    tops = {m.split(".")[1] for m in MODULES if m.count(".") >= 1} - {"__main__"}
    assert tops == set(LAYERS) | LEAF_NAMES, (tops ^ (set(LAYERS) | LEAF_NAMES))
    assert not set(LAYERS) & LEAF_NAMES


def task_parameters() -> list[tuple[str, str, str | None]]:
    """(module, function, annotation or None) of every parameter named ``task``."""
    found = []
    for m, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                for a in node.args.posonlyargs + node.args.args + node.args.kwonlyargs:
                    if a.arg == "task":
                        found.append((m, node.name, ast.unparse(a.annotation) if a.annotation else None))
    return found


def test_every_task_parameter_is_annotated():
    """``task`` is the commonest parameter: from the tasks layer up it is a ``Task`` (or a task's
    name, ``str``); below tasks, and in a leaf, a Protocol that says what is read."""
    wrong = []
    for m, function, annotation in task_parameters():
        above = layer(m) >= LAYERS.index("tasks")
        if annotation is None or (above and "Task" not in annotation and annotation != "str"):
            wrong.append(f"{m}.{function}: {annotation}")
    assert not wrong, wrong
    assert len(task_parameters()) > 50  # the walk does see the signatures


MAX_PARSER_LINES = 250  # a parser module declares flags; more means a command's logic moved in
PLANNER_PARTS = {"encoder", "base", "policy", "predictors"}  # a planner's insides, read only in policies/


def parser_modules() -> dict[str, int]:
    """Lines of each module that declares commands' flags (``parser*.py``, ``*_parser.py``)."""
    return {m: len(p.read_text().splitlines()) for m, p in MODULES.items()
            if re.fullmatch(r"scdp\.cli\.(parser(_\w+)?|\w+_parser)", m)}


def test_parser_modules_stay_small():
    assert len(parser_modules()) >= 5  # the parsers are found
    long = {m: n for m, n in parser_modules().items() if n > MAX_PARSER_LINES}
    assert not long, long


def handler_modules() -> set[str]:
    """The CLI modules a command dispatches to (``handler="module:function"`` in the parsers)."""
    found = set()
    for m in (m for m in MODULES if m.startswith("scdp.cli.")):  # parser_*.py and study_parser.py
        found |= {f"scdp.cli.{h}" for h in re.findall(r'handler="(\w+):\w+"', MODULES[m].read_text())}
    return found


def handler_reach(imports_of=None) -> list[str]:
    """``handler imports handler`` for every CLI handler importing another one."""
    imports_of = imports_of or imports
    handlers = handler_modules()
    return [f"{m} imports {name}" for m in sorted(handlers) for name, _, _ in imports_of(m)
            if name in handlers and name != m]


def test_no_cli_handler_imports_another():
    assert {"scdp.cli.plan", "scdp.cli.serve", "scdp.cli.study"} <= handler_modules()
    assert not handler_reach()


def test_the_handler_check_can_fail():
    planted = lambda m: [("scdp.cli.serve", 3, True)] if m == "scdp.cli.study" else []  # noqa: E731
    assert handler_reach(planted) == ["scdp.cli.study imports scdp.cli.serve"]


def reach_ins(source: str) -> list[str]:
    """``line: expression`` for each read of a planner's parts (:data:`PLANNER_PARTS`) on an object
    whose expression names a planner (``planner.base``, ``self.planners[spec].encoder``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in PLANNER_PARTS and "planner" in ast.unparse(node.value).lower():
            found.append((node.lineno, f"{node.lineno}: {ast.unparse(node)}"))
    return [text for _, text in sorted(found)]


def test_nothing_outside_policies_reads_a_planners_parts():
    outside = {m: p for m, p in MODULES.items() if not m.startswith("scdp.policies")}
    found = {m: hits for m, p in outside.items() if (hits := reach_ins(p.read_text()))}
    assert not found, found


def test_the_reach_in_check_can_fail():
    planted = "def f(planner, service):\n    n = planner.base.config.horizon\n    return service.planners[0].predictors\n"
    assert reach_ins(planted) == ["2: planner.base", "3: service.planners[0].predictors"]
    assert not reach_ins("def g(preset):\n    return preset.base.train\n")  # a preset's sections are not a planner's


EXAMPLE = Path(__file__).parents[1] / "examples" / "planar_arm"


def private_overrides(source: str) -> list[str]:
    """``Class.method`` for each method a class in ``source`` defines with one leading underscore
    (a private hook of the library's bases; dunders are Python's own)."""
    return [f"{node.name}.{item.name}" for node in ast.walk(ast.parse(source)) if isinstance(node, ast.ClassDef)
            for item in node.body if isinstance(item, ast.FunctionDef)
            and item.name.startswith("_") and not item.name.startswith("__")]


def test_the_example_arm_overrides_only_public_hooks():
    sources = {p.name: p.read_text() for p in (EXAMPLE / "task.py", EXAMPLE / "env.py")}
    assert "check_reachable" in sources["task.py"] and "apply_action" in sources["env.py"]  # the hooks are found
    found = {name: hits for name, text in sources.items() if (hits := private_overrides(text))}
    assert not found, found


def test_the_private_override_check_can_fail():
    planted = "class Arm(Task):\n    def _check_reachable(self, g, f):\n        pass\n    def __init__(self):\n        pass\n"
    assert private_overrides(planted) == ["Arm._check_reachable"]
