"""Where the networks run: ``--device auto|cpu|cuda|cuda:K``.

* ``auto`` (the default): the first CUDA GPU when torch sees one, else the CPU.
* ``cpu``; ``cuda`` (the current GPU) or ``cuda:K``, refused with a clear error when torch has
  no CUDA or has fewer GPUs.

Only the networks and their tensors move. Every random draw (initial noise, DDPM's per-step
noise, training noise and shuffling) comes from a CPU ``torch.Generator`` and is copied to the
device, so the same seed gives the same draws on every device; results then differ between
devices only by floating-point rounding in the kernels (reproducible per device).
"""

from __future__ import annotations

from contextlib import contextmanager

import torch

from scdp.errors import ScdpError

CHOICES = "auto, cpu, cuda or cuda:K"


def resolve(spec: str | torch.device | None = "auto", field: str = "--device") -> torch.device:
    """The ``torch.device`` named by ``spec`` (see the module docstring); ``None`` is ``auto``."""
    if isinstance(spec, torch.device):
        spec = str(spec)
    spec = "auto" if spec is None else str(spec).strip().lower()
    if spec == "auto":
        return torch.device("cuda") if torch.cuda.is_available() else torch.device("cpu")
    if spec == "cpu":
        return torch.device("cpu")
    kind, _, index = spec.partition(":")
    if kind != "cuda" or (index and not index.isdigit()):
        raise ScdpError(field, f"unknown device {spec!r} (choose {CHOICES})")
    if not torch.cuda.is_available():
        raise ScdpError(field, f"{spec!r} asked for, but torch sees no CUDA GPU here (torch {torch.__version__}); "
                               "use --device cpu or auto")
    if index and int(index) >= torch.cuda.device_count():
        raise ScdpError(field, f"{spec!r} asked for, but torch sees {torch.cuda.device_count()} GPU(s)")
    return torch.device(spec)


def describe(device: torch.device) -> str:
    """A short human-readable name: ``cpu`` or ``cuda:0 (NVIDIA ...)``."""
    if device.type != "cuda":
        return str(device)
    index = device.index if device.index is not None else torch.cuda.current_device()
    return f"cuda:{index} ({torch.cuda.get_device_name(index)})"


@contextmanager
def training_precision(device: torch.device):
    """While training on a CUDA device, float32 matrix products and convolutions run in TF32 (about
    twice as fast on an Ampere-or-later GPU; the weights stay float32); restored afterwards, so
    planning keeps full float32. Yields the precision: ``"tf32"`` or ``"fp32"`` (CPU)."""
    if device.type != "cuda":
        yield "fp32"
        return
    before = torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32
    torch.backends.cuda.matmul.allow_tf32 = torch.backends.cudnn.allow_tf32 = True
    try:
        yield "tf32"
    finally:
        torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32 = before


def upload(tensor: torch.Tensor, device: torch.device) -> torch.Tensor:
    """A CPU tensor (a draw of a CPU generator) on ``device``: through pinned memory and without
    waiting on a CUDA device, so that a training step does not stop the host for its noise."""
    if device.type != "cuda":
        return tensor.to(device)
    return tensor.pin_memory().to(device, non_blocking=True)
