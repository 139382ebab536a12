"""Tasks from outside the library in tests: a user's module written into the working directory, and
the one check of a task refused at load (by ``get_task`` with the message, and by a command in one
line with nothing written)."""

import textwrap

import pytest

from scdp import tasks
from scdp.cli import main
from scdp.errors import ScdpError
from scdp.tasks import get_task


def user_module(folder, monkeypatch, name: str, source: str):
    """Write ``source`` as the module ``name`` into ``folder``, make ``folder`` the working directory
    and first on the path, and forget the tasks loaded so far: ``folder``."""
    (folder / f"{name}.py").write_text(textwrap.dedent(source))
    monkeypatch.chdir(folder)
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setattr(tasks, "_LOADED", {})
    return folder


def refused_at_load(reference: str, message: str, folder, capsys) -> None:
    """``get_task(reference)`` raises a ``task:`` refusal holding ``message``; ``scdp generate`` with that
    task exits 2 with it as its one line of error, and writes nothing into ``folder``."""
    with pytest.raises(ScdpError, match="^task: ") as refused:
        get_task(reference)
    assert message in str(refused.value), str(refused.value)
    out = folder / "demos.zarr"
    assert main(["generate", "--task", reference, "--num-demos", "4", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("scdp: error: task: ") and message in err[0]
    assert not out.exists()  # refused before anything was written
