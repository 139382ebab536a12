"""A corpus of malformed invocations and files, across all ten subcommands.

Every case runs ``scdp`` in a fresh copy of a sandbox that holds a valid dataset, a valid HDF5
file, the tiny preset's trained checkpoints and a few existing outputs. A case passes when the
command exits 2 with exactly one line ``scdp: error: <field>: <problem>`` naming the expected
field, prints no traceback, and leaves the sandbox byte for byte as it was (no partial output,
no file changed). The importer's repairs are the one exception (:func:`test_importer_repairs`).
"""

import hashlib
import json
import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import h5py
import numpy as np
import pytest
import zarr

from scdp.cli import main
from scdp.data.dataset import DemoDataset
from scdp.perception import block_reach_camera
from scdp.tasks import NAVIGATION

ERROR_LINE = re.compile(r"^scdp: error: (?P<field>[^:]+): (?P<problem>.+)$")


@dataclass
class Case:
    name: str
    argv: list  # "{S}" is replaced by the sandbox folder
    field: str  # the field the error must name, exactly
    damage: Callable[[Path], None] | None = None  # applied to the sandbox before the run
    detail: str = ""  # ... and words its problem must contain (which --set key, which config.json entry)


# -- damage helpers -------------------------------------------------------------------------------
def write_zarr(path: Path, arrays: dict, attrs: dict) -> None:
    """A zarr group with exactly these arrays and attrs, bypassing every check of DemoDataset."""
    shutil.rmtree(path, ignore_errors=True)
    root = zarr.open_group(str(path), mode="w")
    for name, data in arrays.items():
        root.create_array(name, data=np.ascontiguousarray(data))
    root.attrs["scdp"] = attrs


def zarr_arrays(path: Path) -> tuple[dict, dict]:
    root = zarr.open_group(str(path), mode="r")
    names = ["data/state", "data/action", "data/goal", "data/goals", "meta/episode_ends", "meta/target_index"]
    return {n: np.asarray(root[n][:]) for n in names}, dict(root.attrs["scdp"])


def damage_zarr(change: Callable[[dict, dict], None], name="demos.zarr"):
    def apply(sandbox: Path):
        arrays, attrs = zarr_arrays(sandbox / name)
        change(arrays, attrs)
        write_zarr(sandbox / name, arrays, attrs)
    return apply


def set_value(key, index, value):
    def change(arrays, attrs):
        arrays[key] = arrays[key].astype(np.float64) if np.issubdtype(arrays[key].dtype, np.floating) else arrays[key]
        arrays[key][index] = value
    return change


def edit_config(part: str, change: Callable[[dict], object], *, replace: bool = False):
    """Change a part's config.json in place with ``change(meta)``, or (``replace``) write what it returns."""
    def apply(sandbox: Path):
        path = sandbox / "ckpt" / part / "config.json"
        meta = json.loads(path.read_text())
        result = change(meta)
        path.write_text(json.dumps(result if replace else meta))
    return apply


def write_file(relative: str, content: bytes | str):
    def apply(sandbox: Path):
        path = sandbox / relative
        path.write_bytes(content if isinstance(content, bytes) else content.encode())
    return apply


def flip_bytes(part: str, where: float = 0.7):
    def apply(sandbox: Path):
        path = sandbox / "ckpt" / part / "model.safetensors"
        data = bytearray(path.read_bytes())
        i = int(len(data) * where)
        data[i:i + 4] = bytes(b ^ 0xFF for b in data[i:i + 4])
        path.write_bytes(bytes(data))
    return apply


def truncate(part: str):
    def apply(sandbox: Path):
        path = sandbox / "ckpt" / part / "model.safetensors"
        path.write_bytes(path.read_bytes()[: len(path.read_bytes()) // 2])
    return apply


def remove(relative: str):
    return lambda sandbox: (sandbox / relative).unlink()


def foreign_weights(sandbox: Path):
    """Block Reach's base weights in Navigation's base folder, with a matching checksum."""
    shutil.copy(sandbox / "other_base" / "model.safetensors", sandbox / "ckpt" / "base" / "model.safetensors")
    digest = hashlib.sha256((sandbox / "ckpt" / "base" / "model.safetensors").read_bytes()).hexdigest()
    edit_config("base", lambda m: m.update(weights_sha256=digest))(sandbox)


def h5(build: Callable[[h5py.File, dict], None]):
    """An HDF5 file ``bad.hdf5`` built from the sandbox's first demo by ``build(file, episode)``."""
    def apply(sandbox: Path):
        episode = DemoDataset.load(sandbox / "demos.zarr").episode(0)
        with h5py.File(sandbox / "bad.hdf5", "w") as f:
            build(f, episode)
    return apply


def demo_group(f, ep, *, states=None, actions=None, obj=None, skip=(), extra=None, name="demo_0"):
    g = f.create_group(f"data/{name}")
    goals = np.asarray(ep["goals"])[[ep["target"], 1 - ep["target"]]].reshape(-1)
    values = {"states": ep["state"] if states is None else states, "actions": ep["action"] if actions is None else actions,
              "obs/object": np.repeat(goals[None], len(ep["state"]), 0) if obj is None else obj, **(extra or {})}
    for key, value in values.items():
        if key not in skip:
            g[key] = value
    return g


def jump(ep):
    actions = ep["action"].copy()
    actions[len(actions) // 2] += 5.0
    return actions


# -- the corpus -----------------------------------------------------------------------------------
NAV = ["--task", "navigation"]
PLAN = ["plan", *NAV, "--checkpoints", "{S}/ckpt", "--goals", "2.0,0.3", "2.0,-0.3", "--out", "{S}/plan.json"]
PLAN_DP = [*PLAN, "--method", "dp"]
EVAL = ["evaluate", *NAV, "--checkpoints", "{S}/ckpt", "--scenes", "1", "--methods", "dp"]
TRAIN = ["train", "base", *NAV, "--preset", "tiny", "--data", "{S}/demos.zarr", "--out", "{S}/new_ckpt"]

DEPLOY = ["deploy", "--task", "block_reach", "--checkpoints", "{S}/br_ckpt", "--no-video", "--out", "{S}/deployed"]
CAMERA = block_reach_camera().to_dict()

ARGUMENT_CASES = [
    Case("unknown command", ["frobnicate"], "command"),
    Case("threads zero", ["--threads", "0", "inspect", "{S}/demos.zarr"], "--threads"),
    Case("threads text", ["--threads", "many", "inspect", "{S}/demos.zarr"], "--threads"),
    # generate
    Case("generate no task", ["generate", "--out", "{S}/g.zarr"], "--task"),
    Case("generate unknown task", ["generate", "--task", "moon", "--out", "{S}/g.zarr"], "task"),
    Case("generate no out", ["generate", *NAV], "--out"),
    Case("generate negative demos", ["generate", *NAV, "--num-demos", "-5", "--out", "{S}/g.zarr"], "--num-demos"),
    Case("generate float demos", ["generate", *NAV, "--num-demos", "1e11", "--out", "{S}/g.zarr"], "--num-demos"),
    Case("generate absurd demos", ["generate", *NAV, "--num-demos", "100000000000", "--out", "{S}/g.zarr"], "--num-demos"),
    Case("generate zero demos", ["generate", *NAV, "--num-demos", "0", "--out", "{S}/g.zarr"], "--num-demos"),
    Case("generate negative seed", ["generate", *NAV, "--seed", "-1", "--out", "{S}/g.zarr"], "--seed"),
    Case("generate float seed", ["generate", *NAV, "--seed", "1.5", "--out", "{S}/g.zarr"], "--seed"),
    Case("generate bad scenes", ["generate", *NAV, "--scenes", "sometimes", "--out", "{S}/g.zarr"], "--scenes"),
    Case("generate layout 7", ["generate", *NAV, "--scenes", "layout_7", "--out", "{S}/g.zarr"], "--scenes"),
    Case("generate empty out", ["generate", *NAV, "--out", ""], "--out"),
    Case("generate blank out", ["generate", *NAV, "--out", "  "], "--out"),
    Case("generate existing out", ["generate", *NAV, "--num-demos", "1", "--out", "{S}/existing.zarr"], "--out"),
    Case("generate out under a file", ["generate", *NAV, "--num-demos", "1", "--out", "{S}/notes.txt/g.zarr"], "--out"),
    # inspect / plot-demos
    Case("inspect no path", ["inspect"], "path"),
    Case("inspect missing", ["inspect", "{S}/nope.zarr"], "dataset"),
    Case("inspect a text file", ["inspect", "{S}/notes.txt"], "dataset"),
    Case("inspect an hdf5 file", ["inspect", "{S}/good.hdf5"], "dataset"),
    Case("plot-demos no out", ["plot-demos", "{S}/demos.zarr"], "--out"),
    Case("plot-demos txt out", ["plot-demos", "{S}/demos.zarr", "--out", "{S}/d.txt"], "--out"),
    Case("plot-demos no suffix", ["plot-demos", "{S}/demos.zarr", "--out", "{S}/d"], "--out"),
    Case("plot-demos empty out", ["plot-demos", "{S}/demos.zarr", "--out", ""], "--out"),
    Case("plot-demos existing out", ["plot-demos", "{S}/demos.zarr", "--out", "{S}/existing.png"], "--out"),
    Case("plot-demos negative max", ["plot-demos", "{S}/demos.zarr", "--max-demos", "-1", "--out", "{S}/d.png"], "--max-demos"),
    Case("plot-demos text max", ["plot-demos", "{S}/demos.zarr", "--max-demos", "all", "--out", "{S}/d.png"], "--max-demos"),
    Case("plot-demos missing data", ["plot-demos", "{S}/nope.zarr", "--out", "{S}/d.png"], "dataset"),
    # import-hdf5 arguments
    Case("import no task", ["import-hdf5", "{S}/good.hdf5", "--out", "{S}/i.zarr"], "--task"),
    Case("import no out", ["import-hdf5", "{S}/good.hdf5", *NAV], "--out"),
    Case("import existing out", ["import-hdf5", "{S}/good.hdf5", *NAV, "--out", "{S}/existing.zarr"], "--out"),
    Case("import missing file", ["import-hdf5", "{S}/nope.hdf5", *NAV, "--out", "{S}/i.zarr"], "hdf5"),
    Case("import text file", ["import-hdf5", "{S}/notes.txt", *NAV, "--out", "{S}/i.zarr"], "hdf5"),
    Case("import goal dim 0", ["import-hdf5", "{S}/good.hdf5", *NAV, "--goal-dim", "0", "--out", "{S}/i.zarr"], "--goal-dim"),
    Case("import goal dim 9", ["import-hdf5", "{S}/good.hdf5", *NAV, "--goal-dim", "9", "--out", "{S}/i.zarr"], "--goal-dim"),
    Case("import goal dim text", ["import-hdf5", "{S}/good.hdf5", *NAV, "--goal-dim", "xy", "--out", "{S}/i.zarr"], "--goal-dim"),
    Case("import wrong task", ["import-hdf5", "{S}/good.hdf5", "--task", "block_reach", "--out", "{S}/i.zarr"], "data/demo_0/states"),
    # ambiguity-report / plot-ellipse
    Case("ambiguity no task", ["ambiguity-report"], "--task"),
    Case("ambiguity negative scenes", ["ambiguity-report", *NAV, "--scenes", "-3"], "--scenes"),
    Case("ambiguity zero scenes", ["ambiguity-report", *NAV, "--scenes", "0"], "--scenes"),
    Case("ambiguity absurd scenes", ["ambiguity-report", *NAV, "--scenes", "5000000"], "--scenes"),
    Case("ambiguity negative seed", ["ambiguity-report", *NAV, "--seed", "-9"], "--seed"),
    Case("ambiguity existing out", ["ambiguity-report", *NAV, "--scenes", "10", "--out", "{S}/existing.json"], "--out"),
    Case("ambiguity empty out", ["ambiguity-report", *NAV, "--scenes", "10", "--out", ""], "--out"),
    Case("ellipse no goals", ["plot-ellipse", *NAV, "--out", "{S}/e.png"], "--goals"),
    Case("ellipse one goal", ["plot-ellipse", *NAV, "--goals", "2,0", "--out", "{S}/e.png"], "goals"),
    Case("ellipse nan goal", ["plot-ellipse", *NAV, "--goals", "nan,0", "2,1", "--out", "{S}/e.png"], "goals"),
    Case("ellipse text goal", ["plot-ellipse", *NAV, "--goals", "a,b", "2,1", "--out", "{S}/e.png"], "--goals"),
    Case("ellipse bad ext", ["plot-ellipse", *NAV, "--goals", "2,0.3", "2,-0.3", "--out", "{S}/e.jpg"], "--out"),
    Case("ellipse existing", ["plot-ellipse", *NAV, "--goals", "2,0.3", "2,-0.3", "--out", "{S}/existing.png"], "--out"),
    Case("ellipse target 5", ["plot-ellipse", *NAV, "--goals", "2,0.3", "2,-0.3", "--target", "5", "--out", "{S}/e.png"], "target"),
    Case("ellipse goal at start", ["plot-ellipse", *NAV, "--goals", "0.1,0", "2,-0.3", "--out", "{S}/e.png"], "goals"),
    # train arguments
    Case("train no part", ["train", *NAV, "--out", "{S}/c"], "part"),
    Case("train unknown part", ["train", "brain", *NAV, "--out", "{S}/c"], "part"),
    Case("train no out", ["train", "base", *NAV, "--preset", "tiny", "--data", "{S}/demos.zarr"], "--out"),
    Case("train no data", ["train", "base", *NAV, "--preset", "tiny", "--out", "{S}/c"], "--data"),
    Case("train missing data", [*TRAIN[:-4], "--data", "{S}/nope.zarr", "--out", "{S}/c"], "dataset"),
    Case("train unknown preset", ["train", "base", *NAV, "--preset", "huge", "--data", "{S}/demos.zarr", "--out", "{S}/c"], "--preset"),
    Case("train unknown section", [*TRAIN, "--set", "brain.lr=1"], "--set"),
    Case("train unknown field", [*TRAIN, "--set", "base.train.speed=1"], "--set", detail="base.train.speed"),
    Case("train not json", [*TRAIN, "--set", "base.train.lr=fast"], "--set", detail="base.train.lr"),
    Case("train negative lr", [*TRAIN, "--set", "base.train.lr=-1"], "--set", detail="base.train.lr"),
    Case("train string epochs", [*TRAIN, "--set", "base.train.epochs=\"2\""], "--set", detail="base.train.epochs"),
    Case("train no equals", [*TRAIN, "--set", "base.train.lr"], "--set"),
    Case("train zero batch", [*TRAIN, "--set", "base.train.batch_size=0"], "--set", detail="base.train.batch_size"),
    Case("train out is a file", [*TRAIN[:-1], "{S}/notes.txt"], "--out"),
    Case("train out of strangers", [*TRAIN[:-1], "{S}/strangers"], "--out"),
    Case("train over a checkpoint", [*TRAIN[:-1], "{S}/ckpt/base"], "--out"),
    Case("train other task's data", ["train", "base", "--task", "block_reach", "--preset", "tiny", "--data", "{S}/demos.zarr",
                                     "--out", "{S}/c"], "task"),
    Case("train style without base", ["train", "style", *NAV, "--preset", "tiny", "--data", "{S}/demos.zarr",
                                      "--out", "{S}/lonely/style_legible"], "checkpoints/base"),
    Case("train resume changed data", [*TRAIN[:-1], "{S}/partial", "--resume", "--data", "{S}/other.zarr"], "--resume"),
    Case("train resume changed config", [*TRAIN[:-1], "{S}/partial", "--resume", "--set", "base.train.lr=0.005"], "--resume"),
    # plan arguments
    Case("plan no checkpoints", ["plan", *NAV, "--goals", "2,0.3", "2,-0.3", "--out", "{S}/p.json"], "--checkpoints"),
    Case("plan missing checkpoints", [*PLAN[:4], "{S}/nope", *PLAN[5:]], "--checkpoints"),
    Case("plan one goal", [*PLAN[:6], "2,0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan coincident goals", [*PLAN[:6], "2,0.3", "2,0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan nan goal", [*PLAN[:6], "nan,0.3", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan inf goal", [*PLAN[:6], "inf,0.3", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan goal far away", [*PLAN[:6], "40,0.3", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan goal at start", [*PLAN[:6], "0,0", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan goal in success radius", [*PLAN[:6], "0.1,0.05", "2,-0.3", "--out", "{S}/p.json"], "goals"),
    Case("plan 3-d goals", [*PLAN[:6], "2,0.3,0.1", "2,-0.3,0.1", "--out", "{S}/p.json"], "goals"),
    Case("plan mixed dims", [*PLAN[:6], "2,0.3", "2,-0.3,1", "--out", "{S}/p.json"], "goals"),
    Case("plan text goal", [*PLAN[:6], "left", "2,-0.3", "--out", "{S}/p.json"], "--goals"),
    Case("plan three goals", [*PLAN[:6], "2,0.3", "2,-0.3", "2.5,0", "--out", "{S}/p.json"], "--goals"),
    Case("plan target 2", [*PLAN, "--target", "2"], "target"),
    Case("plan target -1", [*PLAN, "--target", "-1"], "target"),
    Case("plan unknown method", [*PLAN, "--method", "rrt"], "--method"),
    Case("plan unknown style", [*PLAN, "--style", "flashy"], "--style"),
    Case("plan negative seed", [*PLAN, "--seed", "-4"], "--seed"),
    Case("plan empty out", [*PLAN[:-1], ""], "--out"),
    Case("plan existing out", [*PLAN[:-1], "{S}/existing.json"], "--out"),
    Case("plan wrong task", ["plan", "--task", "block_reach", *PLAN[3:6], "0.5,0.1", "0.5,-0.1", "--out", "{S}/p.json"], "task"),
    # evaluate arguments
    Case("evaluate unknown method", [*EVAL[:-1], "foo"], "--methods"),
    Case("evaluate style on dp", [*EVAL[:-1], "dp:legible"], "--methods"),
    Case("evaluate unknown style", [*EVAL[:-1], "scdp:shy"], "--methods"),
    Case("evaluate zero scenes", [*EVAL[:4], "{S}/ckpt", "--scenes", "0"], "--scenes"),
    Case("evaluate negative scenes", [*EVAL[:4], "{S}/ckpt", "--scenes", "-2"], "--scenes"),
    Case("evaluate absurd scenes", [*EVAL[:4], "{S}/ckpt", "--scenes", "99999999"], "--scenes"),
    Case("evaluate layout 0", [*EVAL, "--layout", "0"], "--layout"),
    Case("evaluate layout 7", [*EVAL, "--layout", "7"], "--layout"),
    Case("evaluate negative seed", [*EVAL, "--seed", "-2"], "--seed"),
    Case("evaluate existing out", [*EVAL, "--out", "{S}/existing.json"], "--out"),
    Case("evaluate missing checkpoints", [*EVAL[:4], "{S}/nope", "--methods", "dp"], "--checkpoints"),
    # reproduce arguments
    Case("reproduce unknown preset", ["reproduce", "--preset", "huge", "--out", "{S}/r"], "--preset"),
    Case("reproduce unknown task", ["reproduce", "--task", "moon", "--out", "{S}/r"], "task"),  # as every command: get_task names the field
    Case("reproduce unknown protocol", ["reproduce", "--protocol", "sometimes", "--out", "{S}/r"], "--protocol"),
    Case("reproduce layout 0", ["reproduce", "--protocol", "per_layout", "--layouts", "0", "--out", "{S}/r"], "--layouts"),
    Case("reproduce bad override", ["reproduce", "--preset", "tiny", "--set", "data.num_demos=-3", "--out", "{S}/r"], "--set",
         detail="data.num_demos"),
    Case("reproduce negative seed", ["reproduce", "--preset", "tiny", "--seed", "-1", "--out", "{S}/r"], "--seed"),
    Case("reproduce empty out", ["reproduce", "--preset", "tiny", "--out", ""], "--out"),
    Case("reproduce out is a file", ["reproduce", "--preset", "tiny", "--out", "{S}/notes.txt"], "--out"),
    # deploy arguments and calibration files
    Case("deploy navigation", [*DEPLOY[:2], "navigation", *DEPLOY[3:]], "--task"),
    Case("deploy missing checkpoints", [*DEPLOY[:4], "{S}/nope", *DEPLOY[5:]], "--checkpoints"),
    Case("deploy negative scene seed", [*DEPLOY, "--scene-seed", "-1"], "--scene-seed"),
    Case("deploy zero scenes", [*DEPLOY, "--scenes", "0"], "--scenes"),
    Case("deploy margin zero", [*DEPLOY, "--margin", "0"], "--margin"),
    Case("deploy existing out", [*DEPLOY[:-1], "{S}/strangers"], "--out"),
    Case("deploy camera missing", [*DEPLOY, "--camera", "{S}/nope.json"], "--camera"),
    Case("deploy camera not json", [*DEPLOY, "--camera", "{S}/notes.txt"], "--camera"),
    Case("deploy camera a list", [*DEPLOY, "--camera", "{S}/cam.json"], "camera", write_file("cam.json", "[1, 2]")),
    Case("deploy camera non-rigid", [*DEPLOY, "--camera", "{S}/cam.json"], "base_from_camera",
         write_file("cam.json", json.dumps({**CAMERA, "base_from_camera": [[2, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1]]}))),
    Case("deploy camera distorted", [*DEPLOY, "--camera", "{S}/cam.json"], "d",
         write_file("cam.json", json.dumps({**CAMERA, "d": [0.1, 0, 0, 0, 0]}))),
    Case("deploy camera sees no block", [*DEPLOY, "--camera", "{S}/cam.json"], "detections",
         write_file("cam.json", json.dumps({**CAMERA, "base_from_camera": [[1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]]}))),
]

ZARR_DAMAGE = [  # (name, damage, field the error names)
    ("nan state", damage_zarr(set_value("data/state", (3, 0), np.nan)), "data/state"),
    ("inf action", damage_zarr(set_value("data/action", (5, 1), np.inf)), "data/action"),
    ("1e30 state", damage_zarr(set_value("data/state", (7, 0), 1e30)), "data/state"),  # a bad state, not a bad action
    ("2 m jump in an action", damage_zarr(set_value("data/action", (9, 0), 2.0)), "data/action"),
    ("target out of range", damage_zarr(set_value("meta/target_index", 0, 5)), "meta/target_index"),
    ("negative target", damage_zarr(set_value("meta/target_index", 1, -1)), "meta/target_index"),
    ("one goal per scene", damage_zarr(lambda a, m: a.update({"data/goals": a["data/goals"][:, :1]})), "data/goals"),
    ("zero episodes", damage_zarr(lambda a, m: a.update({k: v[:0] for k, v in a.items()})), "meta/episode_ends"),
    ("wrong task tag", damage_zarr(lambda a, m: m.update(task="block_reach")), "task"),
    ("unknown task tag", damage_zarr(lambda a, m: m.update(task="moon")), "task"),
    ("no format version", damage_zarr(lambda a, m: m.pop("format_version")), "dataset"),
    ("4-D states", damage_zarr(lambda a, m: a.update({"data/state": np.pad(a["data/state"], ((0, 0), (0, 1))),
                                                      "data/action": np.pad(a["data/action"], ((0, 0), (0, 1)))})), "task"),
    ("ends not increasing", damage_zarr(lambda a, m: a["meta/episode_ends"].__setitem__(0, a["meta/episode_ends"][1])),
     "meta/episode_ends"),
    ("ends past the data", damage_zarr(lambda a, m: a["meta/episode_ends"].__setitem__(-1, 10**6)), "meta/episode_ends"),
    ("float ends", damage_zarr(lambda a, m: a.update({"meta/episode_ends": a["meta/episode_ends"] + 0.5})), "meta/episode_ends"),
    ("short actions", damage_zarr(lambda a, m: a.update({"data/action": a["data/action"][:-1]})), "data/action"),
    ("corrupt zarr.json", write_file("demos.zarr/zarr.json", "{not json"), "dataset"),
    ("missing action array", lambda s: shutil.rmtree(s / "demos.zarr" / "data" / "action"), "dataset"),
]
ZARR_COMMANDS = {  # every command that reads a dataset
    "inspect": ["inspect", "{S}/demos.zarr"],
    "plot-demos": ["plot-demos", "{S}/demos.zarr", "--out", "{S}/d.png"],
    "train": TRAIN,
}
ZARR_CASES = [Case(f"{cmd}: {name}", argv, field, damage) for name, damage, field in ZARR_DAMAGE
              for cmd, argv in ZARR_COMMANDS.items()]

HDF5_DAMAGE = [
    ("no data group", h5(lambda f, ep: f.create_group("stuff")), "hdf5"),
    ("data is a dataset", h5(lambda f, ep: f.create_dataset("data", data=np.zeros(3))), "hdf5"),
    ("no demo groups", h5(lambda f, ep: f.create_group("data/trial_0")), "hdf5"),
    ("demo is a dataset", h5(lambda f, ep: f.create_dataset("data/demo_0", data=np.zeros(3))), "data/demo_0"),
    ("states is a group", h5(lambda f, ep: demo_group(f, ep, skip=("states",)).create_group("states")), "data/demo_0/states"),
    ("missing actions", h5(lambda f, ep: demo_group(f, ep, skip=("actions",))), "data/demo_0/actions"),
    ("missing obs/object", h5(lambda f, ep: demo_group(f, ep, skip=("obs/object",))), "data/demo_0/obs/object"),
    ("empty obs/object", h5(lambda f, ep: demo_group(f, ep, obj=np.zeros((0,)))), "data/demo_0/obs/object"),
    ("empty states", h5(lambda f, ep: demo_group(f, ep, states=np.zeros((0, 3)), actions=np.zeros((0, 3)))), "data/demo_0/states"),
    ("one-step demo", h5(lambda f, ep: demo_group(f, ep, states=ep["state"][:1], actions=ep["action"][:1],
                                                  obj=None)), "data/demo_0"),
    ("nan states", h5(lambda f, ep: demo_group(f, ep, states=np.where(np.arange(len(ep["state"]))[:, None] == 2, np.nan,
                                                                      ep["state"]))), "data/demo_0/states"),
    ("inf actions", h5(lambda f, ep: demo_group(f, ep, actions=ep["action"] * np.inf)), "data/demo_0/actions"),
    ("states 4 wide", h5(lambda f, ep: demo_group(f, ep, states=np.pad(ep["state"], ((0, 0), (0, 1))),
                                                  actions=np.pad(ep["action"], ((0, 0), (0, 1))))), "data/demo_0/states"),
    ("actions shorter", h5(lambda f, ep: demo_group(f, ep, actions=ep["action"][:-1])), "data/demo_0/actions"),
    ("text states", h5(lambda f, ep: demo_group(f, ep, states=np.array(["a"] * len(ep["state"]), dtype="S1"))), "data/demo_0/states"),
    ("goals of 3 values", h5(lambda f, ep: demo_group(f, ep, obj=np.zeros((len(ep["state"]), 3)) + 1.0)), "data/demo_0/obs/object"),
    ("goals 3-d array", h5(lambda f, ep: demo_group(f, ep, obj=np.ones((len(ep["state"]), 2, 2)))), "data/demo_0/obs/object"),
    ("one goal", h5(lambda f, ep: demo_group(f, ep, obj=np.asarray(ep["goals"])[ep["target"]][None])), "data/demo_0/obs/object"),
    ("goal outside workspace", h5(lambda f, ep: demo_group(f, ep, obj=np.array([40.0, 0.0, 2.0, -0.3]))), "data/demo_0/obs/object"),
    ("coincident goals", h5(lambda f, ep: demo_group(f, ep, obj=np.array([2.0, 0.3, 2.0, 0.3]))), "data/demo_0/obs/object"),
    ("nan goal", h5(lambda f, ep: demo_group(f, ep, obj=np.array([np.nan, 0.3, 2.0, -0.3]))), "data/demo_0/obs/object"),
    ("jump mid-demo", h5(lambda f, ep: demo_group(f, ep, actions=jump(ep))), "data/demo_0/actions"),
    ("dones too short", h5(lambda f, ep: demo_group(f, ep, extra={"dones": np.zeros(3)})), "data/demo_0/dones"),
    ("only sentinels", h5(lambda f, ep: demo_group(f, ep, actions=np.zeros_like(ep["action"]))), "data/demo_0/actions"),
    ("second demo broken", h5(lambda f, ep: (demo_group(f, ep), demo_group(f, ep, skip=("states",), name="demo_1"))),
     "data/demo_1/states"),
]
HDF5_CASES = [Case(f"import-hdf5: {name}", ["import-hdf5", "{S}/bad.hdf5", *NAV, "--out", "{S}/i.zarr"], field, damage)
              for name, damage, field in HDF5_DAMAGE]

CHECKPOINT_DAMAGE = [  # (name, damage, field, problem words, planner that reads the damaged part)
    ("config missing", remove("ckpt/base/config.json"), "checkpoints/base", "", "dp"),
    ("config not json", write_file("ckpt/base/config.json", "{oops"), "checkpoints/base", "", "dp"),
    ("config empty", write_file("ckpt/base/config.json", ""), "checkpoints/base", "", "dp"),
    ("config a list", edit_config("base", lambda m: [m], replace=True), "checkpoints/base", "", "dp"),
    ("config null", write_file("ckpt/base/config.json", "null"), "checkpoints/base", "", "dp"),
    ("normalizer missing", edit_config("base", lambda m: m.pop("normalizer")), "checkpoints/base", "normalizer", "dp"),
    ("normalizer short", edit_config("base", lambda m: m["normalizer"]["state"].update(
        {k: v[:-1] for k, v in m["normalizer"]["state"].items()})), "checkpoints/base", "normalizer", "dp"),
    ("normalizer text", edit_config("base", lambda m: m["normalizer"].update(state="wide")), "checkpoints/base", "normalizer", "dp"),
    ("model config text", edit_config("base", lambda m: m["config"].update(step_embed_dim="sixteen")), "checkpoints/base",
     "step_embed_dim", "dp"),
    ("model config negative", edit_config("base", lambda m: m["config"].update(horizon=-4)), "checkpoints/base", "horizon", "dp"),
    ("model config unknown key", edit_config("base", lambda m: m["config"].update(wings=2)), "checkpoints/base", "wings", "dp"),
    ("config not a dict", edit_config("base", lambda m: m.update(config=[1, 2])), "checkpoints/base", "", "dp"),
    ("wrong task", edit_config("base", lambda m: m.update(task="block_reach")), "task", "block_reach", "dp"),
    ("wrong part", edit_config("base", lambda m: m.update(part="encoder")), "checkpoints/base", "holds a 'encoder'", "dp"),
    ("format version", edit_config("base", lambda m: m.update(format_version=99)), "checkpoints/base", "format", "dp"),
    ("incomplete", edit_config("base", lambda m: m.update(complete=False)), "checkpoints/base", "", "dp"),
    ("checksum edited", edit_config("base", lambda m: m.update(weights_sha256="0" * 64)), "checkpoints/base", "model.safetensors", "dp"),
    ("weights flipped", flip_bytes("base"), "checkpoints/base", "model.safetensors", "dp"),
    ("weights flipped early", flip_bytes("base", 0.2), "checkpoints/base", "model.safetensors", "dp"),
    ("weights truncated", truncate("base"), "checkpoints/base", "model.safetensors", "dp"),
    ("weights missing", remove("ckpt/base/model.safetensors"), "checkpoints/base", "model.safetensors", "dp"),
    ("weights are text", write_file("ckpt/base/model.safetensors", "hello"), "checkpoints/base", "model.safetensors", "dp"),
    ("another task's weights", foreign_weights, "checkpoints/base", "do not fit", "dp"),
    ("ld flipped", flip_bytes("ld"), "checkpoints/ld", "model.safetensors", "ld"),
    ("ld guidance text", edit_config("ld", lambda m: m.update(guidance="strong")), "checkpoints/ld", "guidance", "ld"),
    ("encoder flipped", flip_bytes("encoder"), "checkpoints/encoder", "model.safetensors", "scdp"),
    ("encoder config list", edit_config("encoder", lambda m: [m], replace=True), "checkpoints/encoder", "", "scdp"),
    ("style flipped", flip_bytes("style_legible"), "checkpoints/style_legible", "model.safetensors", "scdp"),
    ("style missing", lambda s: shutil.rmtree(s / "ckpt" / "style_efficient"), "checkpoints/style_efficient", "", "scdp"),
    ("style wrong part", edit_config("style_legible", lambda m: m.update(part="style_efficient")), "checkpoints/style_legible",
     "holds a 'style_efficient'", "scdp"),
]
CHECKPOINT_CASES = [Case(f"plan {method}: {name}", [*PLAN, "--method", method], field, damage, detail)
                    for name, damage, field, detail, method in CHECKPOINT_DAMAGE]
CHECKPOINT_CASES += [Case(f"evaluate {method}: {name}", [*EVAL[:-1], method], field, damage, detail)
                     for name, damage, field, detail, method in CHECKPOINT_DAMAGE[::4]]

CASES = ARGUMENT_CASES + ZARR_CASES + HDF5_CASES + CHECKPOINT_CASES


# -- the sandbox ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def pristine(tiny_reproduction, tmp_path_factory):
    """Valid inputs every case starts from, built once."""
    root = tmp_path_factory.mktemp("fuzz") / "sandbox"
    nav = tiny_reproduction / "navigation"
    root.mkdir()
    shutil.copytree(nav / "demos.zarr", root / "demos.zarr")
    shutil.copytree(nav / "demos.zarr", root / "existing.zarr")
    shutil.copytree(nav / "checkpoints", root / "ckpt")
    shutil.copytree(tiny_reproduction / "block_reach" / "checkpoints", root / "br_ckpt")
    shutil.copytree(tiny_reproduction / "block_reach" / "checkpoints" / "base", root / "other_base")
    data = DemoDataset.load(root / "demos.zarr")
    data.subset(range(data.num_episodes - 1)).save(root / "other.zarr")
    (root / "notes.txt").write_text("a user's notes\n")
    (root / "existing.png").write_bytes(b"\x89PNG user's figure")
    (root / "existing.json").write_text('{"mine": true}')
    (root / "strangers").mkdir()
    (root / "strangers" / "thesis.tex").write_text("\\chapter{}")
    with h5py.File(root / "good.hdf5", "w") as f:
        for k in range(3):
            demo_group(f, data.episode(k), name=f"demo_{k}")
    # an interrupted training: the lr is the tiny preset's, its data demos.zarr
    assert main([*[a.replace("{S}", str(root)) for a in TRAIN[:-1]], str(root / "partial"),
                 "--set", "base.train.epochs=3"]) == 0
    meta = json.loads((root / "partial" / "config.json").read_text())
    meta["complete"] = False
    (root / "partial" / "config.json").write_text(json.dumps(meta))
    return root


def snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir")
            for p in sorted(folder.rglob("*"))}


def run_case(sandbox: Path, argv: list, capsys):
    argv = [a.replace("{S}", str(sandbox)) for a in argv]
    try:
        code = main(argv)
    except BaseException as exc:  # noqa: BLE001 - an escaped exception is the failure being looked for
        capsys.readouterr()
        return None, f"{type(exc).__name__}: {exc}"
    return code, capsys.readouterr().err


def test_the_corpus_is_large_and_covers_every_command():
    commands = {c.argv[0] for c in CASES if not c.argv[0].startswith("-")}
    assert len(CASES) >= 150
    assert commands >= {"generate", "inspect", "plot-demos", "import-hdf5", "ambiguity-report", "plot-ellipse", "train",
                        "plan", "evaluate", "reproduce", "deploy"}


def refused_line(case: Case, pristine: Path, tmp_path: Path, capsys) -> str:
    """Run ``case`` in a fresh copy of the sandbox and check a clean refusal: exit 2, exactly one line
    ``scdp: error: <field>: <problem>`` on the case's exact field (its problem holding ``case.detail``),
    no traceback, nothing written or changed. Returns the line."""
    sandbox = tmp_path / "s"
    shutil.copytree(pristine, sandbox)
    if case.damage:
        case.damage(sandbox)
    before = snapshot(sandbox)
    code, err = run_case(sandbox, case.argv, capsys)
    lines = err.strip().splitlines()
    assert code == 2, f"exit {code}: {err.strip()[-400:]}"
    assert len(lines) == 1 and "Traceback" not in err, err[-600:]
    match = ERROR_LINE.match(lines[0])
    assert match, lines[0][:300]
    assert match["field"] == case.field, lines[0][:300]  # the exact field, not a word of the problem
    assert case.detail in match["problem"], lines[0][:300]
    assert snapshot(sandbox) == before  # nothing written, nothing changed
    return lines[0]


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_malformed_input_is_refused_cleanly(case, pristine, tmp_path, capsys):
    refused_line(case, pristine, tmp_path, capsys)


@pytest.mark.parametrize("build", [
    lambda f, ep: demo_group(f, ep, states=np.vstack([ep["state"], ep["action"][-1:]]),
                             actions=np.vstack([ep["action"], np.zeros((1, 3))])),  # an all-zero "done" action
    lambda f, ep: demo_group(f, ep, states=np.vstack([ep["state"], ep["action"][-1:], np.zeros((2, 3))]),
                             actions=np.vstack([ep["action"], np.zeros((3, 3))]),
                             extra={"dones": np.r_[np.zeros(len(ep["state"])), 1, 0, 0]}),  # steps after done
], ids=["zero sentinel", "after dones"])
def test_importer_repairs(build, pristine, tmp_path, capsys):
    sandbox = tmp_path / "s"
    shutil.copytree(pristine, sandbox)
    h5(build)(sandbox)
    code, err = run_case(sandbox, ["import-hdf5", "{S}/bad.hdf5", *NAV, "--out", "{S}/i.zarr"], capsys)
    assert code == 0 and len(err.strip().splitlines()) == 1 and err.startswith("scdp: warning: dropped "), err
    imported = DemoDataset.load(sandbox / "i.zarr")
    original = DemoDataset.load(sandbox / "demos.zarr").episode(0)
    episode = imported.episode(0)
    assert imported.num_episodes == 1 and imported.attrs["dropped_steps"] >= 1
    assert len(episode["state"]) in (len(original["state"]), len(original["state"]) + 1)
    assert NAVIGATION.reach_used(episode["state"], episode["action"]).max() <= 1.0
    assert np.allclose(episode["state"][: len(original["state"])], original["state"], atol=1e-6)
