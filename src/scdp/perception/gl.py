"""The OpenGL context of MuJoCo's off-screen renderer, chosen when scdp first renders, never at import.

MuJoCo picks its context class from ``MUJOCO_GL`` when it is imported, and PyOpenGL fixes its
platform (``PYOPENGL_PLATFORM``) when it is first imported. A choice made at import would make
every command depend on an OpenGL library (on a machine without libEGL, ``import mujoco`` under
``MUJOCO_GL=egl`` dies with an AttributeError), though only a few commands render. So scdp leaves
both unset at import (MuJoCo then holds its GLFW class, which needs no PyOpenGL) and
:func:`new_renderer` picks the context on the first render:

* the user's ``MUJOCO_GL`` when set: ``egl`` or ``osmesa`` as asked, other values MuJoCo's own class;
* else, with a ``DISPLAY``, MuJoCo's default (GLFW);
* else EGL where libEGL loads, then OSMesa where libOSMesa loads.

The first choice that renders stays for the process (PyOpenGL cannot change platform once
loaded). Where none works, one :class:`~scdp.errors.ScdpError` (field ``render``) names the Debian
packages to install.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
import threading

import mujoco

from scdp.errors import ScdpError

# MUJOCO_GL values that turn MuJoCo's rendering off (as MuJoCo reads them)
OFF = ("disable", "disabled", "off", "false", "0")
# the shared library each headless backend loads through PyOpenGL, and the Debian packages providing it
LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
PACKAGES = {"egl": "libegl1 and libgl1-mesa-dri", "osmesa": "libosmesa6"}
NAMES = {"egl": "EGL", "osmesa": "OSMesa", "default": "MuJoCo's default context (GLFW)"}

_LOCK = threading.Lock()
_CHOSEN: dict = {}  # "name", "cls": the backend that rendered first (cls None: MuJoCo's own class)


def candidates() -> list[str]:
    """The backends to try, in order, from the environment as it is now."""
    asked = os.environ.get("MUJOCO_GL", "").strip().lower()
    if asked:
        return [asked]
    if os.environ.get("DISPLAY"):
        return ["default"]
    return ["egl", "osmesa"]


def library_loads(name: str) -> bool:
    """Whether ``lib<name>.so`` (or a numbered ``.so.N``) can be loaded, looked up the way PyOpenGL
    does on Linux, without importing PyOpenGL."""
    for filename in [f"lib{name}.so"] + [f"lib{name}.so.{n}" for n in range(10)]:
        try:
            ctypes.CDLL(filename)
        except OSError:
            continue
        return True
    return False


def context_class(name: str) -> type | None:
    """The GL context class of backend ``name``; None for MuJoCo's own (GLFW, or what it chose at import).

    A headless backend's module is imported here, on first use: importing it imports PyOpenGL and
    fixes its platform, which is the choice this module keeps away from import time (hence
    ``importlib`` rather than an import statement)."""
    if name in OFF:
        raise RuntimeError("turns MuJoCo's rendering off")
    if name not in LIBRARIES:
        return None
    if not library_loads(LIBRARIES[name]):
        raise RuntimeError(f"lib{LIBRARIES[name]} not found")
    return importlib.import_module(f"mujoco.{name}").GLContext


def build(model: mujoco.MjModel, height: int, width: int, cls: type | None) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` whose GL context is a ``cls`` (None: MuJoCo's own class).

    The Renderer has no context argument: it builds its context from the ``GLContext`` of its
    module's ``gl_context`` when constructed (mujoco.rendering.classic.renderer; mujoco.renderer
    before 4.0). So ``cls`` is put there for the construction and the previous value restored."""
    if cls is None:
        return mujoco.Renderer(model, height, width)
    holder = getattr(sys.modules[mujoco.Renderer.__module__], "gl_context", None)
    if holder is None:
        raise RuntimeError(f"this mujoco ({mujoco.__version__}) builds its renderer's context in an unknown way; "
                           "set MUJOCO_GL before mujoco is imported")
    with _LOCK:
        missing = object()
        before = getattr(holder, "GLContext", missing)
        holder.GLContext = cls
        try:
            return mujoco.Renderer(model, height, width)
        finally:
            if before is missing:
                del holder.GLContext
            else:
                holder.GLContext = before


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def refusal(tried: list[tuple[str, str]]) -> str:
    """The one-line message when no backend in ``tried`` ((name, why) pairs) rendered."""
    why = "; ".join(f"{NAMES.get(name, f'MUJOCO_GL={name}')}: {reason}" for name, reason in tried)
    names = [name for name, _ in tried]
    if names == ["egl", "osmesa"]:
        fix = (f"install Debian's {PACKAGES['egl']} (EGL) or {PACKAGES['osmesa']} (OSMesa), "
               "or run with a DISPLAY")
    elif names == ["default"]:
        fix = "check the display, or set MUJOCO_GL=egl (or osmesa) to render off-screen"
    elif names[0] in PACKAGES:
        fix = f"install Debian's {PACKAGES[names[0]]}, or unset MUJOCO_GL (scdp then tries EGL, then OSMesa)"
    else:
        fix = "unset MUJOCO_GL (scdp then tries EGL, then OSMesa) or set it to egl or osmesa"
    return f"no OpenGL context for off-screen rendering ({why}); {fix}"


def new_renderer(model: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
    """A ``mujoco.Renderer`` of ``model`` at ``height`` x ``width``, on the backend this process chose
    at its first render (see the module docstring); :class:`ScdpError` ``render`` where none works."""
    if _CHOSEN:
        try:
            return build(model, height, width, _CHOSEN["cls"])
        except Exception as exc:  # any failure to open a GL context becomes the one-line refusal
            raise ScdpError("render", refusal([(_CHOSEN["name"], _one_line(exc))])) from None
    tried = []
    for name in candidates():
        try:
            cls = context_class(name)
            renderer = build(model, height, width, cls)
        except Exception as exc:  # a missing library raises AttributeError, ImportError, OSError, ...
            tried.append((name, _one_line(exc)))
            continue
        _CHOSEN.update(name=name, cls=cls)
        return renderer
    raise ScdpError("render", refusal(tried))
