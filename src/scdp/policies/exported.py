"""The exported denoiser: ONNX beside the checkpoint, run by ONNX Runtime, parity-checked.

Planning is the denoiser called 20 times per chunk; everything around it (the sampler loop, the
scheduler, the style predictors and the scene encoder, once per chunk) stays in torch. So one
graph per diffusion part is exported, the route deployment projects in the field take:

    checkpoints/base/model.onnx   ConditionalUnet1D: x (B, H, S), k (B,), cond (B, G),
                                  gamma, beta (B, W) -> eps (B, H, S), B dynamic
    checkpoints/base/onnx.json    opset, input names, the film layout, the sampler and the
                                  normalisation the graph expects, the parity it passed, and
                                  the SHA-256 of the weights it was exported from and of itself

The style film inputs always have the width of every block (``film_channels("all")``): DP and LD
send γ = 1, β = 0 (the base function exactly), a bottleneck-only film (the paper's design) is
placed at the first bottleneck block's slice. One graph serves every planner of the folder.

:func:`export_denoiser` writes both files through a temporary path and renames them into place
only after the graph matches torch on random inputs (batches 1 and 8, identity and random films)
within :data:`PARITY_TOLERANCE`; otherwise it refuses, naming the worst case and its error.
:class:`OnnxDenoiser` is a drop-in for the policy's ``unet``: the same call, the same tensors out.
It refuses a graph exported from other weights than the folder's ``model.safetensors`` (a part
retrained after its export; training also removes the graph) or a damaged one, in one line.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import onnxruntime as ort
import torch
from torch import nn

from scdp.config.planning import AUTO_BATCH
from scdp.content import file_sha256
from scdp.errors import ScdpError
from scdp.io import atomic_path, read_json_object, write_json
from scdp.models.film import Film, FilmLayout
from scdp.models.unet1d import ConditionalUnet1D
from scdp.policies.checkpoint import ONNX_FILE, ONNX_META
from scdp.threads import planning_threads

INPUTS, OUTPUT = ("x", "k", "cond", "gamma", "beta"), "eps"
OPSET = 17
PARITY_TOLERANCE = 1e-4  # largest |eps_onnx - eps_torch| accepted, in scaled action units
PARITY_BATCHES = (1, 8)


class _FilmAsInputs(nn.Module):
    """The U-Net with its style film as two plain inputs, for the exporter."""

    def __init__(self, unet: ConditionalUnet1D):
        super().__init__()
        self.unet = unet

    def forward(self, x, k, cond, gamma, beta):
        return self.unet(x, k, cond, Film(gamma, beta, "all"))


def film_layout(unet: ConditionalUnet1D) -> dict:
    """The U-Net's film layout as ``onnx.json`` stores it (:class:`scdp.models.film.FilmLayout`)."""
    return unet.film_layout.to_dict()


def _random_inputs(unet: ConditionalUnet1D, horizon: int, state_dim: int, cond_dim: int, batch: int, identity: bool,
                   generator: torch.Generator, steps: int) -> dict[str, torch.Tensor]:
    width = film_layout(unet)["width"]
    gamma = torch.ones(batch, width) if identity else 1 + 0.2 * torch.randn(batch, width, generator=generator)
    beta = torch.zeros(batch, width) if identity else 0.2 * torch.randn(batch, width, generator=generator)
    return {"x": torch.randn(batch, horizon, state_dim, generator=generator),
            "k": torch.randint(0, steps, (batch,), generator=generator),
            "cond": torch.randn(batch, cond_dim, generator=generator), "gamma": gamma, "beta": beta}


def session(path: Path, threads: int | None = None) -> ort.InferenceSession:
    """An ONNX Runtime CPU session of ``path`` on ``threads`` intra-op threads (default: torch's count)."""
    options = ort.SessionOptions()
    options.intra_op_num_threads = threads or torch.get_num_threads()
    options.inter_op_num_threads = 1
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    # idle threads sleep rather than spin, as torch's do under scdp (scdp.threads): the sampler loop, the
    # predictors and the simulator run on the same cores between two denoiser calls
    options.add_session_config_entry("session.intra_op.allow_spinning", "0")
    return ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])


def parity(unet: ConditionalUnet1D, sess: ort.InferenceSession, shapes: dict, seed: int = 0) -> dict:
    """The largest |ONNX - torch| over random inputs: ``{"max_abs_error", "worst"}`` (the case that gave it)."""
    generator = torch.Generator().manual_seed(seed)
    worst = {"max_abs_error": 0.0, "worst": None}
    for batch in PARITY_BATCHES:
        for identity in (True, False):
            inputs = _random_inputs(unet, generator=generator, batch=batch, identity=identity, **shapes)
            with torch.no_grad():
                want = unet(inputs["x"], inputs["k"], inputs["cond"], Film(inputs["gamma"], inputs["beta"], "all")).numpy()
            got = sess.run([OUTPUT], {n: t.numpy() for n, t in inputs.items()})[0]
            err = float(np.max(np.abs(got - want)))
            if not np.isfinite(err) or err > worst["max_abs_error"]:
                worst = {"max_abs_error": err, "worst": f"{OUTPUT} at batch {batch}, {'identity' if identity else 'random'} film"}
    return worst


def export_denoiser(unet: ConditionalUnet1D, folder, *, horizon: int, state_dim: int, cond_dim: int, steps: int,
                    extra: dict | None = None, tolerance: float = PARITY_TOLERANCE) -> dict:
    """Export ``unet`` as ``folder/model.onnx`` with ``folder/onnx.json``; refuse (nothing written)
    when the graph's worst error on random inputs exceeds ``tolerance``. Returns the metadata."""
    folder = Path(folder)
    unet = unet.eval().cpu()
    shapes = {"horizon": horizon, "state_dim": state_dim, "cond_dim": cond_dim, "steps": steps}
    example = _random_inputs(unet, generator=torch.Generator().manual_seed(0), batch=1, identity=True, **shapes)
    with atomic_path(folder / ONNX_FILE) as tmp:
        with torch.no_grad(), warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the tracer's notes on Python-side checks of shapes it records as constants
            torch.onnx.export(_FilmAsInputs(unet), tuple(example[n] for n in INPUTS), str(tmp), input_names=list(INPUTS),
                              output_names=[OUTPUT], dynamic_axes={n: {0: "batch"} for n in (*INPUTS, OUTPUT)},
                              opset_version=OPSET, dynamo=False)
        check = parity(unet, session(tmp, threads=1), shapes)
        if not check["max_abs_error"] <= tolerance:
            raise ScdpError(f"{folder.name}/{ONNX_FILE}", f"fails parity with torch: {check['worst']} is off by "
                                                          f"{check['max_abs_error']:.3g} (tolerance {tolerance:g}); nothing written")
        weights = folder / "model.safetensors"
        meta = {"opset": OPSET, "inputs": list(INPUTS), "output": OUTPUT, "film": film_layout(unet), **shapes,
                "parity": {**check, "tolerance": tolerance, "batches": list(PARITY_BATCHES)},
                "weights_sha256": file_sha256(weights) if weights.is_file() else None, "onnx_sha256": file_sha256(tmp),
                **(extra or {})}
        write_json(folder / ONNX_META, meta)
    return meta


class OnnxDenoiser(nn.Module):
    """The exported U-Net behind the torch U-Net's call: ``(x, k, global_cond, film=None) -> eps``.

    Holds no parameters; ``bottleneck_dim``, ``film_channels`` and ``film_width`` answer as the
    torch network did, so the policies and loaders around it do not change.
    """

    def __init__(self, folder, threads: int | None = None):
        super().__init__()
        folder = Path(folder)
        try:
            self.meta = json.loads((folder / ONNX_META).read_text())
        except (OSError, ValueError):
            raise ScdpError("--runtime", f"{folder} has no exported denoiser ({ONNX_META}); run scdp export on its "
                                         "checkpoints folder first") from None
        self.check_bound(folder)
        if threads is None:  # sized now, as planning will size torch's pool (an idle second thread costs a wake-up a call)
            threads = planning_threads((read_json_object(folder / "config.json") or {}).get("parameters", 0))
        try:
            self.session = session(folder / ONNX_FILE, threads)
        except Exception as exc:  # ONNX Runtime's own errors (InvalidProtobuf, Fail, ...) share no base class
            raise ScdpError("--runtime", f"{folder / ONNX_FILE} cannot be loaded ({type(exc).__name__}); "
                                         "re-export it with scdp export --force") from None
        self.layout = self.meta["film"]
        self.film_layout = FilmLayout.from_dict(self.layout)
        self.bottleneck_dim = self.film_layout.bottleneck_dim
        # one call now, at load: ONNX Runtime allocates its buffers on the first run, not in a robot's first chunk
        self(torch.zeros(1, self.meta["horizon"], self.meta["state_dim"]), torch.zeros(1, dtype=torch.long),
             torch.zeros(1, self.meta["cond_dim"]))

    def check_bound(self, folder: Path) -> None:
        """Refuse a graph that is not the one exported (damaged, replaced) or was exported from other
        weights than the folder's, naming the fix."""
        fix = f"re-export with scdp export --checkpoints {folder.parent} --force"
        graph, weights = folder / ONNX_FILE, folder / "model.safetensors"
        recorded = self.meta.get("weights_sha256")
        if recorded is None or not weights.is_file() or file_sha256(weights) != recorded:
            raise ScdpError("--runtime", f"{graph} was exported from other weights than {weights}; {fix}")
        if not graph.is_file() or file_sha256(graph) != self.meta.get("onnx_sha256"):
            raise ScdpError("--runtime", f"{graph} is not the graph that was exported (missing, damaged or replaced); {fix}")

    def film_channels(self, blocks: str) -> list[int]:
        return self.film_layout.channels(blocks)

    def film_width(self, blocks: str) -> int:
        return self.film_layout.width(blocks)

    def forward(self, x: torch.Tensor, k: torch.Tensor, global_cond: torch.Tensor, film=None) -> torch.Tensor:
        gamma, beta = self.film_layout.full(film, x.shape[0])
        feeds = {"x": x.float().cpu().numpy(), "k": k.long().cpu().numpy(), "cond": global_cond.float().cpu().numpy(),
                 "gamma": gamma.numpy(), "beta": beta.numpy()}
        return torch.from_numpy(self.session.run([OUTPUT], feeds)[0]).to(x.device)



class AutoDenoiser(nn.Module):
    """``--runtime auto``: the exported graph for small batches (a robot's control loop, the service
    at low load), the torch network for large ones (``evaluate``), where ONNX Runtime's CPU kernels
    fall behind torch's batched ones. Both are the same weights (the graph is bound to them); they
    agree within the export's parity tolerance, so a scene's plan may differ in the last digits
    between a batch of 1 and a batch of 200."""

    def __init__(self, unet: ConditionalUnet1D, folder, threads: int | None = None):
        super().__init__()
        self.net, self.onnx = unet, OnnxDenoiser(folder, threads)
        self.bottleneck_dim = unet.bottleneck_dim

    def film_channels(self, blocks: str) -> list[int]:
        return self.net.film_channels(blocks)

    def film_width(self, blocks: str) -> int:
        return self.net.film_width(blocks)

    def forward(self, x: torch.Tensor, k: torch.Tensor, global_cond: torch.Tensor, film=None) -> torch.Tensor:
        if x.shape[0] < AUTO_BATCH:
            return self.onnx(x, k, global_cond, film)
        return self.net(x, k, global_cond, film)
