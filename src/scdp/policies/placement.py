"""Where a diffusion network runs at planning time, decided in one place from the planning options.

Three choices make it: the runtime (``--runtime``: torch, the exported ONNX graph, or ``auto``), the
device (``--device``) and the CUDA-graph switch (``--cuda-graphs``). :func:`place` turns them into a
:class:`Placement`; :func:`~scdp.policies.loaders.load_diffusion` installs the denoiser it names, and
:meth:`Placement.replays` tells :meth:`~scdp.policies.diffusion.DiffusionPolicy.sample` whether a
chunk's loop (:func:`scdp.policies.sampling.denoise`) replays from one CUDA graph or runs eager.
docs/speed.md's "What runs where" table is :func:`placement_table` (``tests/test_placement.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

from scdp.config.planning import AUTO_BATCH
from scdp.keys import RUNTIMES


@dataclass(frozen=True)
class Placement:
    """``denoiser``: ``torch`` (the network on ``device``), ``onnx`` (the exported graph, ONNX Runtime on
    the CPU) or ``auto`` (the graph below :data:`AUTO_BATCH` scenes per call, torch from there on, on the
    CPU); ``graphs``: whether a plain DDPM loop may replay from one CUDA graph on a CUDA device."""

    denoiser: str = "torch"
    device: str = "cpu"
    graphs: bool = True

    def replays(self, device_type: str, plain_ddpm: bool) -> bool:
        """Whether a chunk on ``device_type`` replays its loop from one CUDA graph: the DDPM sampler with
        the plain network call (a guided call's per-chunk weights, DDIM and DPM-Solver are not graph
        inputs), the torch network, on a CUDA device, the switch on."""
        return self.graphs and plain_ddpm and self.denoiser == "torch" and device_type == "cuda"

    def words(self, plain_ddpm: bool) -> str:
        """What runs a chunk, in words (a cell of :func:`placement_table`)."""
        if self.denoiser == "onnx":
            return "the exported graph (ONNX Runtime, CPU), eager loop"
        if self.denoiser == "auto":
            return f"the exported graph below {AUTO_BATCH} scenes per call, torch from there on; eager loop"
        loop = "the loop replayed from one CUDA graph" if self.replays(self.device, plain_ddpm) else "eager loop"
        return f"torch on the {self.device.upper() if self.device == 'cpu' else 'GPU'}, {loop}"


def place(runtime: str, device_type: str, cuda_graphs: bool, exported: bool) -> Placement:
    """The placement of a network for ``--runtime`` ``runtime`` on a ``device_type`` device
    (``cpu``/``cuda``), ``--cuda-graphs`` on or off, and whether its folder holds an exported graph:
    ``onnx`` always runs the graph on the CPU; ``auto`` runs it on a CPU where it was exported, and the
    torch network elsewhere (a GPU, or no graph); ``torch`` runs torch on the device."""
    if runtime not in RUNTIMES:
        raise ValueError(f"unknown runtime {runtime!r}")
    if runtime == "onnx":
        return Placement("onnx", "cpu", False)
    if runtime == "auto" and device_type == "cpu" and exported:
        return Placement("auto", "cpu", False)
    return Placement("torch", device_type, cuda_graphs)


def placement_table() -> str:
    """The planning rows of docs/speed.md's "What runs where", from :func:`place` (graphs on, exported)."""
    rows = ["| `--runtime` | planner's call | CPU | CUDA GPU |", "|---|---|---|---|"]
    for runtime in RUNTIMES:
        for plain, call in ((True, "DDPM, the plain network call"),
                            (False, "LD's guidance, SCDP's `style_guidance`, DDIM, DPM-Solver++")):
            cells = [place(runtime, device, True, True).words(plain) for device in ("cpu", "cuda")]
            rows.append(f"| {runtime} | {call} | {cells[0]} | {cells[1]} |")
    return "\n".join(rows)
