"""The Panda drawn with Franka's meshes: on the DH frames, massless, and capsules when absent.

The expected placement of every mesh is written here from franka_description's URDF (link i's mesh in
link i's frame; the hand on the flange turned -pi/4 about z; each finger 0.0584 m along the hand's z
and 0.04 m to its side when open, the right one turned pi), not read from scdp's own constants.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from scdp.errors import ScdpError
from scdp.robots import panda, panda_meshes

FOLDER = panda_meshes.mesh_folder()


def _rz(angle: float, x=0.0, y=0.0, z=0.0) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0, x], [s, c, 0, y], [0, 0, 1, z], [0, 0, 0, 1.0]])


def _file_vertices(stem: str) -> np.ndarray:
    """The STL's vertices in its own frame: the mesh alone at the world origin (MuJoCo re-centres a
    mesh and gives its geom the offset back, so the world positions are the file's)."""
    xml = (f'<mujoco><asset><mesh name="m" file="{(FOLDER / f"{stem}.stl").as_posix()}"/></asset>'
           '<worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    return d.geom_xpos[0] + m.mesh_vert @ d.geom_xmat[0].reshape(3, 3).T


def _world_vertices(model, data, geom: str) -> np.ndarray:
    g = model.geom(geom)
    start, count = model.mesh_vertadr[g.dataid[0]], model.mesh_vertnum[g.dataid[0]]
    return data.geom(geom).xpos + model.mesh_vert[start:start + count] @ data.geom(geom).xmat.reshape(3, 3).T


def test_the_meshes_are_installed_for_the_tests():
    assert FOLDER is not None, panda_meshes.mesh_source()  # the test extra installs scdp[meshes]


def test_every_mesh_sits_on_its_dh_frame_within_a_millimetre_at_20_configurations():
    model = panda.model(meshes=True)
    data = mujoco.MjData(model)
    stems = {"base": "link0", **{f"link{i}": f"link{i}" for i in range(1, 8)}}
    files = {s: _file_vertices(s) for s in [*stems.values(), "hand", "finger"]}
    rng = np.random.default_rng(20)
    worst = 0.0
    for q in rng.uniform(panda.Q_MIN, panda.Q_MAX, size=(20, 7)):
        data.qpos[:7] = q
        mujoco.mj_kinematics(model, data)
        frames = panda.joint_frames(q)  # (8, 4, 4): links 1..7 and the flange, from the datasheet
        expected = {"base": np.eye(4), **{f"link{i}": frames[i - 1] for i in range(1, 8)}}
        hand = frames[7] @ _rz(-np.pi / 4)
        placed = {**{b: (T, stems[b]) for b, T in expected.items()}, "hand": (hand, "hand"),
                  "finger_left": (hand @ _rz(0.0, y=0.04, z=0.0584), "finger"),
                  "finger_right": (hand @ _rz(np.pi, y=-0.04, z=0.0584), "finger")}
        for name, (T, stem) in placed.items():
            want = files[stem] @ T[:3, :3].T + T[:3, 3]
            got = _world_vertices(model, data, name + panda_meshes.MESH_SUFFIX)
            worst = max(worst, float(np.abs(got - want).max()))
    assert worst < 1e-3, f"a mesh vertex is {worst * 1000:.2f} mm off its frame"


def test_meshes_change_neither_the_dynamics_nor_the_kinematics():
    runs = []
    for meshes in (True, False):
        model = panda.model(meshes=meshes)
        data = mujoco.MjData(model)
        data.qpos[:7] = panda.READY_POSE
        data.ctrl[:] = panda.READY_POSE + 0.3
        mujoco.mj_step(model, data, nstep=300)
        runs.append((data.qpos[:7].copy(), data.site("tcp").xpos.copy(), model.body_mass.copy()))
    for with_meshes, capsules in zip(*runs):
        np.testing.assert_array_equal(with_meshes, capsules)
    assert runs[0][0].std() > 0  # it moved


def test_capsules_are_hidden_under_the_meshes_and_drawn_without_them():
    with_meshes, without = panda.model(meshes=True), panda.model(meshes=False)
    assert panda_meshes.arm_look(with_meshes) == "meshes" and panda_meshes.arm_look(without) == "capsules"
    mesh = int(mujoco.mjtGeom.mjGEOM_MESH)
    capsules = [i for i in range(with_meshes.ngeom) if int(with_meshes.geom_type[i]) != mesh
                and with_meshes.body(int(with_meshes.geom_bodyid[i])).name.startswith(("link", "flange"))]
    assert len(capsules) == 8
    shown = mujoco.MjvOption().geomgroup  # what a default render shows
    assert all(not shown[with_meshes.geom_group[i]] for i in capsules)
    assert all(shown[without.geom_group[i]] for i in range(without.ngeom))
    meshes = [i for i in range(with_meshes.ngeom) if int(with_meshes.geom_type[i]) == mesh]
    assert len(meshes) == 11 and all(shown[with_meshes.geom_group[i]] for i in meshes)


def test_asking_for_meshes_that_are_absent_names_the_extra(monkeypatch):
    monkeypatch.setattr(panda_meshes, "mesh_folder", lambda: None)
    with pytest.raises(ScdpError, match=r"meshes: .*pip install scdp\[meshes\]"):
        panda.mjcf(meshes=True)
    assert panda_meshes.arm_look(mujoco.MjModel.from_xml_string(panda.mjcf())) == "capsules"  # the fallback
