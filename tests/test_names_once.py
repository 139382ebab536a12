"""Part and scene-set names are made and read in one place, ``scdp.keys``: no other module spells a
style part (``"style_legible"``, ``f"style_{style}"``) or a layout's scene set (``"layout_3"``,
``f"layout_{k}"``), or parses one by prefix (``startswith("style")``, ``rsplit("_", 1)``).
Comments and docstrings may name them; code asks ``keys`` (``style_part``, ``is_style_part``,
``part_style``, ``layout_name``, ``layout_number``)."""

import io
import re
import tokenize
from pathlib import Path

SRC = Path(__file__).parents[1] / "src" / "scdp"
SPELLED = re.compile(r"""^[rRbBfF]*['"](style_(legible|efficient|paper|\{)|layout_(\d|\{))""")
PARSED = re.compile(r"""^[rRbBfF]*['"](style|layout_|_)['"]?""")


def violations(source: str) -> list[str]:
    """Each place ``source`` spells or parses a part or layout name by hand, as ``line: text``."""
    tokens = [t for t in tokenize.generate_tokens(io.StringIO(source).readline)
              if t.type not in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT)]
    found = []
    for i, tok in enumerate(tokens):
        text = tok.string
        if tokenize.tok_name[tok.type] == "FSTRING_START" and i + 1 < len(tokens):  # Python 3.12: f"..." in parts
            text += tokens[i + 1].string + "{"
        if tok.type == tokenize.STRING or tokenize.tok_name[tok.type] == "FSTRING_START":
            if SPELLED.match(text):
                found.append(f"{tok.start[0]}: {tok.string if tok.type == tokenize.STRING else text}")
        if (tok.type == tokenize.NAME and tok.string in ("startswith", "removeprefix", "rsplit", "split")
                and i + 2 < len(tokens) and tokens[i + 1].string == "("
                and tokens[i + 2].type == tokenize.STRING and PARSED.match(tokens[i + 2].string)):
            found.append(f"{tok.start[0]}: {tok.string}({tokens[i + 2].string}")
    return found


def test_part_and_layout_names_are_made_and_read_only_in_keys():
    found = {str(p.relative_to(SRC)): hits for p in sorted(SRC.rglob("*.py"))
             if p.name != "keys.py" and (hits := violations(p.read_text()))}
    assert not found, found


def test_the_names_check_can_fail():
    planted = '''
def style_of(part):
    # a comment saying "style_legible" or "layout_3" is fine
    """so is a docstring: "layout_k" """
    if part.startswith("style_"):
        return part.rsplit("_", 1)[1]
    return f"layout_{part}", "style_legible", "layout_repeats"
'''
    assert violations(planted) == ['5: startswith("style_"', '6: rsplit("_"', '7: f"layout_{part}"', '7: "style_legible"']
