"""Only rendering needs OpenGL (issue 49): without any OpenGL library, scdp imports and plans, and
a command that renders refuses in one line naming the packages to install.

A machine without libEGL is simulated in a subprocess: before anything else runs, loading any
OpenGL library through ctypes fails as dlopen fails where the file is missing. PyOpenGL loads its
libraries through ctypes, so its EGL platform comes up without libEGL, exactly as on such a machine
(its first EGL call then raises AttributeError on ``eglQueryString``, which the first test checks).
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
NAVIGATION_CHECKPOINTS = ROOT / "results" / "cpu" / "navigation" / "checkpoints"
BLOCK_REACH_CHECKPOINTS = ROOT / "results" / "cpu" / "block_reach" / "checkpoints"

NO_GL = """
import ctypes, ctypes.util, re
_GL = re.compile(r"(^|/)lib(EGL|GL|OpenGL|OSMesa|GLESv1_CM|GLESv2|GLX)([._]|$)")
_load = ctypes.CDLL.__init__
def _no_gl(self, name, *args, **kwargs):
    if name and _GL.search(str(name)):
        raise OSError(f"{name}: cannot open shared object file: No such file or directory")
    _load(self, name, *args, **kwargs)
ctypes.CDLL.__init__ = _no_gl
_find = ctypes.util.find_library
ctypes.util.find_library = lambda name: None if _GL.search("lib" + name) else _find(name)
"""


def without_gl(code: str, **env) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh Python where no OpenGL library loads, headless, with no renderer chosen."""
    base = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL", "PYOPENGL_PLATFORM")}
    base["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT / "src"), os.environ.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-c", NO_GL + code], env={**base, **env}, cwd=ROOT,
                          capture_output=True, text=True, timeout=300)


def test_the_simulation_hides_libegl():
    """PyOpenGL's EGL platform fails as on a machine without libEGL (the crash of issue 49)."""
    pytest.importorskip("OpenGL")
    done = without_gl("from OpenGL import EGL", PYOPENGL_PLATFORM="egl")
    assert done.returncode != 0 and "eglQueryString" in done.stderr, done.stderr[-2000:]


def test_import_and_plan_need_no_opengl(tmp_path):
    out = tmp_path / "p.json"
    done = without_gl(f"""
import os, sys
import scdp, scdp.tasks, scdp.envs, scdp.perception, scdp.deploy
assert "OpenGL" not in sys.modules, "importing scdp imported PyOpenGL"
assert "MUJOCO_GL" not in os.environ and "PYOPENGL_PLATFORM" not in os.environ, "importing scdp chose a renderer"
from scdp.cli import main
sys.exit(main(["plan", "--task", "navigation", "--checkpoints", {str(NAVIGATION_CHECKPOINTS)!r},
               "--goals", "2.0,0.2", "2.0,-0.2", "--steps", "5", "--out", {str(out)!r}]))
""")
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(json.loads(out.read_text())["states"]) > 1


def test_a_command_that_renders_refuses_in_one_line(tmp_path):
    out = tmp_path / "deploy"
    done = without_gl(f"""
import runpy, sys
sys.argv = ["scdp", "deploy", "--task", "block_reach", "--checkpoints", {str(BLOCK_REACH_CHECKPOINTS)!r},
            "--no-video", "--steps", "5", "--out", {str(out)!r}]
runpy.run_module("scdp", run_name="__main__", alter_sys=True)
""")
    assert done.returncode == 2, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("scdp: error: render: "), lines
    for package in ("libegl1", "libgl1-mesa-dri", "libosmesa6"):
        assert package in lines[0]
    assert not out.exists()

