"""Stage names are a type (scdp.pipeline.names.StageName): made from their parts, written as the log
and files write them, read back by one parser; no other module of the pipeline splits a name."""

import io
import pickle
import re
import tokenize
from pathlib import Path

import pytest

from scdp.errors import ScdpError
from scdp.pipeline.names import StageName, evaluation_key, parse_timed

PIPELINE = Path(__file__).parents[1] / "src" / "scdp" / "pipeline"
PARSERS = ("split", "rsplit", "partition", "rpartition", "startswith", "endswith", "removeprefix", "removesuffix", "replace")


def _slashed(tokens) -> bool:
    """Whether the call's first argument is a slash: a string starting with ``/`` or ``{PER_LAYOUT}/``, or ``SEP``."""
    text = tokens[0].string + (tokens[1].string if tokenize.tok_name[tokens[0].type] == "FSTRING_START" else "")
    return text == "SEP" or re.match(r"""^[rRbBfF]*['"](/|\{PER_LAYOUT\}/)""", text) is not None


def string_parsing(source: str) -> list[str]:
    """Each ``.split("/")``-like call on a slash, and each ``"/..." in x`` test, as ``line: text``."""
    tokens = [t for t in tokenize.generate_tokens(io.StringIO(source).readline)
              if t.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT)]
    found = []
    for i, tok in enumerate(tokens):
        following = [t.string for t in tokens[i + 1:i + 3]]
        if (tok.string == "." and len(following) == 2 and following[0] in PARSERS and following[1] == "("
                and _slashed(tokens[i + 3:i + 5])):
            found.append(f"{tok.start[0]}: .{following[0]}({tokens[i + 3].string}")
        elif tok.type == tokenize.STRING and "/" in tok.string and following[:1] == ["in"]:
            found.append(f"{tok.start[0]}: {tok.string} in")
    return found


def test_no_pipeline_module_parses_a_stage_name_by_hand():
    found = {p.name: hits for p in sorted(PIPELINE.glob("*.py")) if p.name != "names.py"
             and (hits := string_parsing(p.read_text()))}
    assert not found, found


def test_the_parsing_check_can_fail():
    planted = '''
task, protocol = key.split("/")
what = group[0].rpartition("/")[0]
if name.startswith(f"{PER_LAYOUT}/"):
    pass
if f"/{PER_LAYOUT}/" in key:
    pass
lock = name.replace(SEP, "--")
'''
    assert [h.split(":")[0] for h in string_parsing(planted)] == ["2", "3", "4", "6", "8"]


@pytest.mark.parametrize("name, parts", [
    (StageName("base"), ("base", "random", None)),
    (StageName("demos", "per_layout", "layout_2"), ("demos", "per_layout", "layout_2")),
    (StageName("evaluate", "per_layout"), ("evaluate", "per_layout", None)),
])
def test_a_name_is_its_text_and_keeps_its_parts(name, parts):
    assert StageName.parse(str(name)) == name and (name.what, name.protocol, name.layout) == parts
    again = pickle.loads(pickle.dumps(name))  # as a Ray worker receives it
    assert (again, again.what, again.protocol, again.layout) == (name, *parts)
    assert parse_timed(name.timed("navigation")) == ("navigation", name)


def test_the_written_forms():
    layout = StageName("base", "per_layout", "layout_2")
    assert layout == "per_layout/layout_2/base" and layout.file_stem == "per_layout--layout_2--base"
    assert layout.model_set == "per_layout/layout_2" and StageName("base").model_set == "models"
    assert evaluation_key("navigation", "random") == "navigation/random"
    for bad in ("", "a/b", "per_layout/", "per_layout/layout_2/base/x"):
        with pytest.raises(ScdpError):
            StageName.parse(bad)
