"""What drawing the Panda with its meshes costs per rendered frame, against the capsules it replaced.

Regenerates: `results/benchmarks/arm_look.md`, `results/benchmarks/arm_look.json`

    python benchmarks/arm_look.py [--frames 30] [--out results/benchmarks/arm_look.md]

Each look renders the same poses (a seeded random walk from the ready pose) through the same path
as every picture scdp writes (:func:`scdp.perception.render_rgbd`: colour and depth), at the observer
camera's size (deploy strips and videos) and at the study's frame size. The looks:

* ``capsules, 4096-texel shadows``: the pictures before the meshes (MuJoCo's default shadow map);
* ``capsules, 1024-texel shadows``: the fallback today, when the meshes are not installed;
* ``meshes, 1024-texel shadows``: the default today (``pip install scdp[meshes]``).

Run alone: times on a software renderer depend on nothing else running. The machine's fp32 matmul
rate is measured in the same run.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

from scdp.io import atomic_path, write_json
from scdp.perception import observer_camera, render_rgbd
from scdp.robots import panda, panda_meshes
from scdp.study.make import FRAME_SIZE

sys.path.insert(0, str(Path(__file__).parent))
from realtime import matmul_gflops  # noqa: E402 (a sibling benchmark)

LOOKS = (("capsules, 4096-texel shadows", False, 4096), ("capsules, 1024-texel shadows", False, 1024),
         ("meshes, 1024-texel shadows", True, 1024))


class Scene:
    """A Panda model and its data: what render_rgbd draws."""

    def __init__(self, meshes: bool, shadow: int):
        self.model = panda.model(meshes=meshes)
        self.model.vis.quality.shadowsize = shadow  # before the renderer (and its shadow map) is made
        self.data = mujoco.MjData(self.model)


def poses(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    steps = rng.normal(0.0, 0.05, size=(n, 7))
    return np.clip(panda.READY_POSE + np.cumsum(steps, axis=0), panda.Q_MIN, panda.Q_MAX)


def per_frame_ms(scene: Scene, camera, path: np.ndarray) -> float:
    scene.data.qpos[:7] = path[0]
    render_rgbd(scene, camera)  # the renderer and its context are made on the first frame: not timed
    start = time.perf_counter()
    for q in path:
        scene.data.qpos[:7] = q
        render_rgbd(scene, camera)
    return (time.perf_counter() - start) / len(path) * 1000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=30, help="frames timed per look and size (default 30)")
    ap.add_argument("--out", type=Path, default=Path("results/benchmarks/arm_look.md"))
    args = ap.parse_args()
    if panda_meshes.mesh_folder() is None:
        sys.exit(f"scdp: error: meshes: {panda_meshes.mesh_source()}")
    path = poses(args.frames)
    cameras = {"observer view (deploy)": observer_camera(), "study frame": observer_camera(*FRAME_SIZE)}
    rows = {look: {name: per_frame_ms(Scene(meshes, shadow), cam, path) for name, cam in cameras.items()}
            for look, meshes, shadow in LOOKS}
    gflops = matmul_gflops()
    record = {"frames": args.frames, "matmul_gflops": gflops, "meshes": panda_meshes.mesh_source(),
              "sizes": {n: [c.width, c.height] for n, c in cameras.items()}, "ms_per_frame": rows}
    head = "| look | " + " | ".join(f"{n} {c.width}x{c.height}, ms/frame" for n, c in cameras.items()) + " |"
    lines = [
        "# The Panda's look: rendering cost per frame", "",
        f"`python benchmarks/arm_look.py --frames {args.frames}`; {args.frames} poses per look and size, colour and "
        f"depth per frame (scdp.perception.render_rgbd), one process, nothing else running. fp32 matmul "
        f"{gflops:.0f} GFLOP/s. Meshes: {panda_meshes.mesh_source()}.", "",
        head, "|" + "---|" * (len(cameras) + 1),
        *[f"| {look} | " + " | ".join(f"{v:.1f}" for v in r.values()) + " |" for look, r in rows.items()], "",
        "Ratios to the pictures before the meshes (capsules, 4096-texel shadows): "
        + "; ".join(f"{n}: {rows[LOOKS[2][0]][n] / rows[LOOKS[0][0]][n]:.2f}x" for n in cameras) + ".", "",
    ]
    with atomic_path(args.out) as tmp:
        tmp.write_text("\n".join(lines))
    write_json(args.out.with_suffix(".json"), record)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
