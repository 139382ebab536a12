"""The Panda's visual meshes: where they are installed, and how they sit on the DH frames.

The meshes are Franka's own (``franka_description``, Apache-2.0), as STL files in metres, shipped
offline by the ``gymnasium-robotics`` wheel (``pip install scdp[meshes]``). Each mesh is expressed in
its link's frame, and those frames are the modified-DH frames of :mod:`scdp.robots.panda` (link
``i`` = frame ``i``; ``link0`` is the base). The hand is bolted to the flange turned -45 degrees about
its z axis; each finger sits 0.0584 m further along it. The package is found without importing it
(``importlib.util.find_spec``), so drawing the arm pulls in nothing but the files.

When the meshes are absent, the arm is drawn with its capsules (the collision geometry), and
:func:`arm_look` says which of the two a compiled model shows.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
from pathlib import Path

import numpy as np

MESH_PACKAGE = "gymnasium-robotics"  # the distribution; ``pip install scdp[meshes]`` pins it
MESH_FOLDER = ("envs", "assets", "kitchen_franka", "franka_assets", "meshes", "visual")
LINK_MESHES = {"base": "link0", **{f"link{i}": f"link{i}" for i in range(1, 8)}}  # body -> STL stem
HAND_YAW = -np.pi / 4  # the hand on the flange, about the flange's z axis
FINGER_OFFSET = 0.0584  # hand frame -> finger frame, along z
FINGER_OPENING = 0.04  # each finger's slide from the centre: the gripper drawn fully open
MESH_SUFFIX = "_mesh"  # a visual geom's name: the body (or hand, finger_left, finger_right) + this
ARM_RGBA = "0.95 0.95 0.97 1"
FINGER_RGBA = "0.25 0.25 0.27 1"
HIDDEN_GROUP = 3  # the capsules' geom group when meshes are drawn: not among MuJoCo's default visible groups
LOOKS = ("meshes", "capsules")


def mesh_folder() -> Path | None:
    """The folder holding the Panda's visual STL files, or None when ``gymnasium-robotics`` is absent
    (or ships them elsewhere)."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        return None
    folder = Path(next(iter(spec.submodule_search_locations))).joinpath(*MESH_FOLDER)
    needed = [*LINK_MESHES.values(), "hand", "finger"]
    return folder if all((folder / f"{stem}.stl").is_file() for stem in needed) else None


def mesh_source() -> str:
    """Where the meshes come from, in words: the package and its version, or why there are none."""
    if mesh_folder() is None:
        return f"none ({MESH_PACKAGE} is not installed: pip install scdp[meshes])"
    return f"{MESH_PACKAGE} {importlib.metadata.version(MESH_PACKAGE)} (Franka's franka_description meshes)"


def _quat_z(angle: float) -> str:
    return f"{np.cos(angle / 2):.10f} 0 0 {np.sin(angle / 2):.10f}"


def asset_xml(folder: Path) -> str:
    """The ``<asset>`` element naming every mesh file by its absolute path."""
    stems = [*LINK_MESHES.values(), "hand", "finger"]
    return "<asset>" + "".join(f'<mesh name="panda_{s}" file="{(folder / f"{s}.stl").as_posix()}"/>' for s in stems) + "</asset>"


def _geom(name: str, mesh: str, rgba: str, pos=(0.0, 0.0, 0.0), yaw: float = 0.0) -> str:
    return (f'<geom name="{name}{MESH_SUFFIX}" type="mesh" mesh="panda_{mesh}" mass="0" rgba="{rgba}" '
            f'pos="{pos[0]:.10f} {pos[1]:.10f} {pos[2]:.10f}" quat="{_quat_z(yaw)}"/>')


def link_geom(body: str) -> str:
    """The visual geom of ``body`` (``base``, ``link1`` .. ``link7``): its mesh at the body's frame."""
    return _geom(body, LINK_MESHES[body], ARM_RGBA)


def hand_geoms() -> str:
    """The hand and both fingers (open), in the flange body's frame."""
    c, s = np.cos(HAND_YAW), np.sin(HAND_YAW)
    geoms = [_geom("hand", "hand", ARM_RGBA, yaw=HAND_YAW)]
    for side, sign in (("finger_left", 1.0), ("finger_right", -1.0)):
        # the finger's origin in the hand frame, (0, sign * opening, offset), turned into the flange frame
        y = sign * FINGER_OPENING
        pos = (-s * y, c * y, FINGER_OFFSET)
        geoms.append(_geom(side, "finger", FINGER_RGBA, pos, HAND_YAW + (0.0 if sign > 0 else np.pi)))
    return "".join(geoms)


def arm_look(model) -> str:
    """``"meshes"`` when the compiled MuJoCo ``model`` draws the Panda with its meshes, else ``"capsules"``."""
    return LOOKS[0] if model.nmesh > 0 else LOOKS[1]


def arm_words(model) -> str:
    """What a picture of ``model`` shows, in words for its caption and record."""
    if arm_look(model) == "meshes":
        return f"Panda drawn with Franka's meshes ({MESH_PACKAGE} {importlib.metadata.version(MESH_PACKAGE)})"
    return "Panda drawn as capsules (for its meshes: pip install scdp[meshes])"
