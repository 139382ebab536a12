"""Check scdp's LeRobot v3 export against the real ``lerobot`` package (0.4.4), offline.

Regenerates: `results/lerobot/check.txt` (run by benchmarks/lerobot_check.sh, which records what it prints)

This script runs INSIDE a separate virtual environment that has lerobot installed; it never imports
scdp. It only calls lerobot's public API, so a PASS here means lerobot itself accepted the files.

Subcommands (one line per check, each starting with PASS or FAIL):

``check DIR``    open DIR with ``LeRobotDataset(repo_id="local/check", root=DIR)`` and check
                 (a) ``ds[0]["task"]`` is a str;
                 (b) QUANTILES normalisation (lerobot's ``NormalizerProcessorStep``, q01/q99) of
                     ``observation.state`` and ``action`` with the dataset's stats;
                 (c) ``dataset_to_policy_features`` calls ``observation.environment_state`` ENV, a small
                     ``DiffusionConfig`` validates against the features and the diffusion policy takes one
                     training forward pass on a DataLoader batch (CPU, seconds);
                 (d) ``dataset_tools.delete_episodes`` (episode 0, on a copy) writes a non-empty stats.json
                     with q01/q99 for ``observation.state``;
                 (e) append: on a copy, reopen for recording (``LeRobotDataset.resume`` where the API has it,
                     else the constructor, which is how lerobot 0.4.4's recorder resumes), add a copy of
                     episode 0 frame by frame, ``save_episode``, ``finalize``, reopen and count episodes.
``write DIR``    lerobot writes a small navigation-like dataset itself (4 episodes x 30 frames, fps 10,
                 robot_type turtlebot3, no videos, task "drive to the goal").
``compare A B``  does B keep A's feature names, robot_type, fps (an int) and task texts?

Building the venv (Python 3.11: lerobot 0.4.4 needs >=3.10 and the only offline torch wheel is cp311;
lerobot pins torch<2.11 and torchvision<0.26, neither of which is available offline, hence --no-deps)::

    /root/.pyenv/versions/3.11.7/bin/python -m venv /tmp/lerobot311
    export PIP_CONSTRAINT=          # keep the global constraints file out of this venv
    /tmp/lerobot311/bin/pip install /opt/wheels/torch-2.13.0+cpu-cp311-cp311-manylinux_2_28_x86_64.whl
    /tmp/lerobot311/bin/pip install --no-deps /tmp/lerobot_src/lerobot-0.4.4-py3-none-any.whl
    /tmp/lerobot311/bin/pip install "datasets>=4,<5" "huggingface-hub>=0.34.2,<0.36" draccus==0.10.0 \
        "jsonlines>=4,<5" "packaging>=24.2,<26" "einops>=0.8,<0.9" "diffusers>=0.27.2,<0.36" "av>=15,<16" \
        "termcolor>=2.4,<4" "deepdiff>=7.0.1,<9" "imageio>=2.34,<3" "gymnasium>=1.1.1,<2" pandas pyarrow \
        safetensors "accelerate>=1.10,<2" "pyserial>=3.5,<4"
    /tmp/lerobot311/bin/pip install torchvision==0.28.0   # the torch 2.13 match; a CUDA build, see below
    /tmp/lerobot311/bin/pip install "numpy<2.4"           # 2.4 breaks 0.4.4 save_episode on shape-(1,) features

The only torchvision offline is a CUDA build whose ``_C.so`` cannot load next to torch+cpu, and
``import torchvision`` then dies registering fake kernels for ``torchvision::nms``/``qnms``. lerobot imports
torchvision everywhere but none of these checks uses its compiled ops, so :func:`_torchvision_shim`
declares those two op schemas when (and only when) ``_C.so`` fails to load.

numpy 2.4 made ``float(np.array([x]))`` an error; lerobot 0.4.4's ``save_episode`` hands the stacked (T, 1)
column of any non-default shape-(1,) feature to ``datasets.Value``, which does exactly that (TypeError "only
0-dimensional arrays can be converted to Python scalars"), so append (e) needs numpy<2.4.

The sequence (scdp env in /work/main for ``scdp``, this venv for the script)::

    cd /work/main
    scdp generate --task navigation --num-demos 12 --seed 1 --out /tmp/lrcheck/demos.zarr --force
    scdp export-demos /tmp/lrcheck/demos.zarr --out /tmp/lrcheck/export --force
    export HF_HUB_OFFLINE=1 HF_DATASETS_OFFLINE=1
    /tmp/lerobot311/bin/python benchmarks/lerobot_check.py check /tmp/lrcheck/export
    /tmp/lerobot311/bin/python benchmarks/lerobot_check.py write /tmp/lrcheck/written
    scdp import-lerobot /tmp/lrcheck/written --task navigation --out /tmp/lrcheck/in.zarr --force
    scdp export-demos /tmp/lrcheck/in.zarr --out /tmp/lrcheck/back --force
    /tmp/lerobot311/bin/python benchmarks/lerobot_check.py compare /tmp/lrcheck/written /tmp/lrcheck/back

Exit status: 0 when every check passed, 1 otherwise.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import shutil
import sys
import tempfile
import time
import traceback
from pathlib import Path

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("HF_DATASETS_OFFLINE", "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402

_KEEP = []  # keeps the shim's torch.library.Library alive


def _torchvision_shim() -> None:
    """Declare torchvision::nms/qnms when torchvision's compiled ops cannot load (CUDA wheel, CPU torch)."""
    spec = importlib.util.find_spec("torchvision")
    if spec is None or spec.origin is None:
        return
    libs = sorted(Path(spec.origin).parent.glob("_C*.so"))
    if not libs:
        return
    try:
        torch.ops.load_library(str(libs[0]))
    except OSError as exc:
        print(f"note: torchvision's _C.so does not load ({exc}); declaring torchvision::nms/qnms schemas only",
              file=sys.stderr)
        lib = torch.library.Library("torchvision", "DEF")
        lib.define("nms(Tensor dets, Tensor scores, float iou_threshold) -> Tensor")
        lib.define("qnms(Tensor dets, Tensor scores, float iou_threshold) -> Tensor")
        _KEEP.append(lib)


_torchvision_shim()

from lerobot.datasets.lerobot_dataset import LeRobotDataset  # noqa: E402
from lerobot.datasets.utils import DEFAULT_FEATURES  # noqa: E402

STATE, ACTION, ENV = "observation.state", "action", "observation.environment_state"


def _where(exc: BaseException) -> str:
    """The innermost traceback frame inside lerobot, as 'lerobot/…/file.py:line'."""
    spot = ""
    for frame in traceback.extract_tb(exc.__traceback__):
        if "/lerobot/" in frame.filename:
            spot = f"{frame.filename[frame.filename.rfind('/lerobot/') + 1:]}:{frame.lineno}"
    return spot or "outside lerobot"


def _report(results: list, label: str, ok: bool, text: str) -> None:
    results.append(ok)
    print(f"{'PASS' if ok else 'FAIL'} {label}: {text}", flush=True)


def _run(results: list, label: str, fn) -> None:
    try:
        ok, text = fn()
    except Exception as exc:  # each check reports its own failure and the rest still run
        ok, text = False, f"{type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else ''} " \
                          f"[at {_where(exc)}]"
    _report(results, label, ok, text)


def _open(root, repo_id: str = "local/check", **kw) -> LeRobotDataset:
    return LeRobotDataset(repo_id=repo_id, root=root, **kw)


def _rng(values: torch.Tensor) -> str:
    lo, hi = values.min(dim=0).values.tolist(), values.max(dim=0).values.tolist()
    return "[" + ", ".join(f"{a:+.3f}..{b:+.3f}" for a, b in zip(lo, hi)) + "]"


# ----------------------------------------------------------------------------------------------- check
def check_task(ds: LeRobotDataset):
    task = ds[0]["task"]
    return isinstance(task, str), f"ds[0]['task'] is {type(task).__name__}: {task!r}"


def check_quantiles(ds: LeRobotDataset):
    from lerobot.configs.types import FeatureType, NormalizationMode, PolicyFeature
    from lerobot.processor import NormalizerProcessorStep
    from lerobot.processor.converters import create_transition

    stats = ds.meta.stats or {}
    missing = [f"{k}/{q}" for k in (STATE, ACTION) for q in ("q01", "q99") if q not in stats.get(k, {})]
    if missing:  # lerobot would silently pass a feature without stats through unchanged
        return False, f"stats.json lacks {missing}"
    features = {STATE: PolicyFeature(FeatureType.STATE, tuple(ds.meta.features[STATE]["shape"])),
                ACTION: PolicyFeature(FeatureType.ACTION, tuple(ds.meta.features[ACTION]["shape"]))}
    step = NormalizerProcessorStep.from_lerobot_dataset(
        ds, features, {FeatureType.STATE: NormalizationMode.QUANTILES, FeatureType.ACTION: NormalizationMode.QUANTILES})
    rows = ds.hf_dataset[:]
    raw = {k: torch.stack(list(rows[k])).float() for k in (STATE, ACTION)}
    out = step(create_transition(observation={STATE: raw[STATE].clone()}, action=raw[ACTION].clone()))
    got = {STATE: out["observation"][STATE], ACTION: out["action"]}
    parts, ok = [], True
    for k in (STATE, ACTION):
        q01 = torch.as_tensor(np.asarray(stats[k]["q01"]), dtype=torch.float32)
        q99 = torch.as_tensor(np.asarray(stats[k]["q99"]), dtype=torch.float32)
        span = q99 - q01
        expect = 2 * (raw[k] - q01) / torch.where(span == 0, torch.tensor(step.eps), span) - 1  # lerobot's eps rule
        err = ((got[k] - expect).abs() / expect.abs().clamp(min=1)).max().item()
        inside = ((got[k] >= -1.05) & (got[k] <= 1.05)).float().mean().item()
        ok &= bool(torch.isfinite(got[k]).all()) and err < 1e-4 and not torch.equal(got[k], raw[k])
        names = ds.meta.features[k].get("names") or list(range(len(span)))
        flat = [f"{names[i]} (q99-q01={span[i].item():.1e})" for i in range(len(span)) if abs(span[i].item()) < 1e-6]
        parts.append(f"{k} -> {_rng(got[k])} ({inside:.1%} within +-1.05, max rel. err vs 2(x-q01)/(q99-q01)-1 = "
                     f"{err:.1e})" + (f" WARNING degenerate {flat}" if flat else ""))
    print(f"  (b) {_recompute(ds, rows)}", flush=True)
    return ok, f"{len(raw[STATE])} frames; " + "; ".join(parts)


def _recompute(ds: LeRobotDataset, rows: dict) -> str:
    """stats.json's q01/q99 against lerobot's own compute_episode_stats + aggregate_stats on the same frames."""
    from lerobot.datasets.compute_stats import aggregate_stats, compute_episode_stats

    ep = np.asarray(rows["episode_index"])
    feats = {k: ds.meta.features[k] for k in (STATE, ACTION)}
    per = [compute_episode_stats({k: torch.stack([rows[k][i] for i in np.flatnonzero(ep == e)]).numpy()
                                  for k in feats}, feats) for e in np.unique(ep)]
    mine = aggregate_stats(per)
    out = []
    for k in feats:
        d = max(float(np.max(np.abs(np.asarray(ds.meta.stats[k][q]) - mine[k][q]))) for q in ("q01", "q99"))
        every = torch.stack(list(rows[k])).double()
        g = torch.quantile(every, torch.tensor([0.01, 0.99], dtype=torch.float64), dim=0)
        out.append(f"{k}: max|stats.json - lerobot recomputed| q01/q99 = {d:.1e}; stats.json q01 "
                   f"{np.round(ds.meta.stats[k]['q01'], 3).tolist()} q99 {np.round(ds.meta.stats[k]['q99'], 3).tolist()}"
                   f" vs pooled-frame quantiles {np.round(g[0].numpy(), 3).tolist()} / {np.round(g[1].numpy(), 3).tolist()}")
    return "; ".join(out)


def check_policy(ds: LeRobotDataset, root: Path):
    from lerobot.configs.types import FeatureType
    from lerobot.datasets.factory import resolve_delta_timestamps
    from lerobot.datasets.utils import dataset_to_policy_features
    from lerobot.policies.diffusion.configuration_diffusion import DiffusionConfig
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    feats = dataset_to_policy_features(ds.meta.features)
    kinds = ", ".join(f"{k}={v.type.name}" for k, v in feats.items())
    if ENV not in feats or feats[ENV].type is not FeatureType.ENV:
        return False, f"{ENV} is not ENV: {kinds}"
    cfg = DiffusionConfig(horizon=16, n_obs_steps=2, n_action_steps=8, down_dims=(32, 64),
                          diffusion_step_embed_dim=32, num_train_timesteps=10, device="cpu", push_to_hub=False)
    cfg.output_features = {k: f for k, f in feats.items() if f.type is FeatureType.ACTION}
    cfg.input_features = {k: f for k, f in feats.items() if k not in cfg.output_features}
    cfg.validate_features()
    print(f"  (c) policy features: {kinds}; DiffusionConfig.validate_features() ok", flush=True)
    t0 = time.perf_counter()
    policy = make_policy(cfg, ds_meta=ds.meta)
    pre, _post = make_pre_post_processors(cfg, dataset_stats=ds.meta.stats)
    train_ds = _open(root, delta_timestamps=resolve_delta_timestamps(cfg, ds.meta))
    loader = torch.utils.data.DataLoader(train_ds, batch_size=8, shuffle=True, num_workers=0,
                                         generator=torch.Generator().manual_seed(0))
    batch = pre(next(iter(loader)))
    policy.train()
    loss, _ = policy.forward(batch)
    loss.backward()
    shapes = ", ".join(f"{k} {tuple(batch[k].shape)}" for k in (STATE, ENV, ACTION))
    ok = bool(torch.isfinite(loss))
    return ok, (f"diffusion forward+backward on a DataLoader batch ({shapes}): loss {loss.item():.4f}, "
                f"{sum(p.numel() for p in policy.parameters()):,} params, {time.perf_counter() - t0:.1f} s")


def check_delete(root: Path, work: Path):
    from lerobot.datasets.dataset_tools import delete_episodes

    src = work / "del_src"
    shutil.copytree(root, src)
    ds = _open(src)
    out = delete_episodes(ds, episode_indices=[0], output_dir=work / "del_out", repo_id="local/check_deleted")
    stats = json.loads((Path(out.root) / "meta" / "stats.json").read_text())
    st = stats.get(STATE, {})
    ok = bool(stats) and "q01" in st and "q99" in st
    q = (f"q01 {np.round(st['q01'], 3).tolist()} q99 {np.round(st['q99'], 3).tolist()}" if ok
         else f"{STATE} stats keys {sorted(st)}")
    return ok, (f"episodes {ds.meta.total_episodes} -> {out.meta.total_episodes}; stats.json has "
                f"{len(stats)} features; {STATE} {q}")


def check_append(root: Path, work: Path):
    src = work / "app_src"
    shutil.copytree(root, src)
    before = _open(src)
    n_before, frames_before = before.meta.total_episodes, before.meta.total_frames
    ep = before.meta.episodes[0]
    lo, hi = int(ep["dataset_from_index"]), int(ep["dataset_to_index"])
    items = [before[i] for i in range(lo, hi)]
    text = items[0]["task"]
    del before
    how = "LeRobotDataset.resume" if hasattr(LeRobotDataset, "resume") else "LeRobotDataset(...) (0.4.4 has no resume)"
    ds = LeRobotDataset.resume(repo_id="local/check", root=src) if hasattr(LeRobotDataset, "resume") else _open(src)
    keys = [k for k in ds.meta.features if k not in DEFAULT_FEATURES]
    for item in items:
        frame = {k: np.asarray(item[k], dtype=ds.meta.features[k]["dtype"]).reshape(ds.meta.features[k]["shape"])
                 for k in keys}
        frame["task"] = item["task"]
        ds.add_frame(frame)
    ds.save_episode()
    ds.finalize()
    after = _open(src)
    last = after[len(after) - 1]
    ok = (after.meta.total_episodes == n_before + 1 and len(after) == frames_before + len(items)
          and last["task"] == text and int(last["episode_index"]) == n_before)
    return ok, (f"via {how}: episodes {n_before} -> {after.meta.total_episodes}, frames {frames_before} -> "
                f"{len(after)}, new episode's task {last['task']!r}, tasks {list(after.meta.tasks.index)}")


def cmd_check(args) -> int:
    root = Path(args.dir)
    results: list = []
    ds = _open(root)
    print(f"opened {root}: {ds.meta.total_episodes} episodes, {len(ds)} frames, fps {ds.meta.fps}, "
          f"robot_type {ds.meta.robot_type!r}, features {list(ds.meta.features)}", flush=True)
    with tempfile.TemporaryDirectory(prefix="lerobot_check_") as tmp:
        work = Path(tmp)
        _run(results, "(a) task", lambda: check_task(ds))
        _run(results, "(b) QUANTILES", lambda: check_quantiles(ds))
        _run(results, "(c) policy", lambda: check_policy(ds, root))
        _run(results, "(d) delete_episodes", lambda: check_delete(root, work))
        _run(results, "(e) append", lambda: check_append(root, work))
    print(f"{sum(results)}/{len(results)} passed")
    return 0 if all(results) else 1


# ----------------------------------------------------------------------------------------------- write
# (g*, other goal) per episode. g* about 1 m away: 30 frames of <= 0.035 m, within a TurtleBot3's 0.22 m/s
# over the 0.2 s control step scdp's navigation task checks actions against.
GOALS = [((0.9, 0.5), (1.5, -0.8)), ((1.0, -0.3), (1.4, 0.9)), ((0.7, -0.7), (1.6, 0.4)), ((0.6, 0.8), (1.2, -1.0))]


def cmd_write(args) -> int:
    root = Path(args.dir)
    if root.exists():
        if not args.force:
            print(f"{root} exists (use --force to replace it)")
            return 1
        shutil.rmtree(root)
    features = {
        # shapes as tuples: 0.4.4's validate_frame compares a frame's shape tuple with this value as given
        STATE: {"dtype": "float32", "shape": (3,), "names": ["px", "py", "yaw"]},
        ACTION: {"dtype": "float32", "shape": (3,), "names": ["x", "y", "theta"]},
        ENV: {"dtype": "float32", "shape": (4,), "names": ["goal_x", "goal_y", "other_x", "other_y"]},
    }
    ds = LeRobotDataset.create(repo_id="local/written", root=root, fps=10, robot_type="turtlebot3",
                               features=features, use_videos=False)
    n = 30
    for goal, other in GOALS:
        g = np.asarray(goal)
        yaw = math.atan2(g[1], g[0])
        pos = [g * t / n for t in range(n + 1)]  # (0,0) ... goal: state t is pos[t], action t is pos[t + 1]
        env = np.asarray([*goal, *other], dtype=np.float32)
        for t in range(n):
            ds.add_frame({STATE: np.asarray([*pos[t], yaw], dtype=np.float32),
                          ACTION: np.asarray([*pos[t + 1], yaw], dtype=np.float32),
                          ENV: env.copy(), "task": "drive to the goal"})
        ds.save_episode()
    ds.finalize()
    back = _open(root, repo_id="local/written")
    print(f"wrote {root}: {back.meta.total_episodes} episodes, {len(back)} frames, fps {back.meta.fps}, "
          f"robot_type {back.meta.robot_type!r}, tasks {list(back.meta.tasks.index)}")
    return 0


# --------------------------------------------------------------------------------------------- compare
def _tasks_per_episode(ds: LeRobotDataset) -> list:
    return [list(ds.meta.episodes[i]["tasks"]) for i in range(ds.meta.total_episodes)]


def cmd_compare(args) -> int:
    for root in (args.a, args.b):
        if not (Path(root) / "meta" / "info.json").is_file():  # else lerobot would try the Hub
            print(f"FAIL open: {root} has no meta/info.json")
            return 1
    a, b = _open(args.a, repo_id="local/a"), _open(args.b, repo_id="local/b")
    results: list = []
    fa, fb = a.meta.features, b.meta.features
    keys = [k for k in fa if k not in DEFAULT_FEATURES]
    diff = [f"{k}: {fa[k].get('names')} -> {fb[k].get('names') if k in fb else 'missing'}"
            for k in keys if k not in fb or fb[k].get("names") != fa[k].get("names")]
    extra = [k for k in fb if k not in fa]
    _report(results, "feature names", not diff,
            ("; ".join(diff) if diff else f"{len(keys)} features, names equal")
            + (f" (B adds {extra})" if extra else ""))
    _report(results, "robot_type", a.meta.robot_type == b.meta.robot_type,
            f"{a.meta.robot_type!r} -> {b.meta.robot_type!r}")
    fps_a, fps_b = a.meta.info["fps"], b.meta.info["fps"]
    _report(results, "fps", type(fps_b) is int and fps_a == fps_b,
            f"{fps_a!r} ({type(fps_a).__name__}) -> {fps_b!r} ({type(fps_b).__name__})")
    ta, tb = list(a.meta.tasks.index), list(b.meta.tasks.index)
    ea, eb = _tasks_per_episode(a), _tasks_per_episode(b)
    item_a, item_b = a[0]["task"], b[0]["task"]
    ok = sorted(ta) == sorted(tb) and ea == eb and item_a == item_b
    _report(results, "task texts", ok, f"tasks {ta} -> {tb}; per-episode equal: {ea == eb}; "
            f"ds[0]['task'] {item_a!r} -> {item_b!r}")
    print(f"{sum(results)}/{len(results)} passed")
    return 0 if all(results) else 1


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog="Run inside the lerobot venv; see the module docstring for the recipe.")
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("check", help="check a LeRobot v3 dataset (e.g. scdp's export) with lerobot itself")
    p.add_argument("dir")
    p.set_defaults(fn=cmd_check)
    p = sub.add_parser("write", help="have lerobot write a small navigation-like dataset")
    p.add_argument("dir")
    p.add_argument("--force", action="store_true", help="replace DIR if it exists")
    p.set_defaults(fn=cmd_write)
    p = sub.add_parser("compare", help="does B keep A's feature names, robot_type, fps and task texts?")
    p.add_argument("a")
    p.add_argument("b")
    p.set_defaults(fn=cmd_compare)
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    torch.manual_seed(0)
    return args.fn(args)


if __name__ == "__main__":
    sys.exit(main())
