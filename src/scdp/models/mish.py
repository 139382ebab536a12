"""Mish, ``x * tanh(softplus(x))``, with a form of its own for ONNX export.

``torch.onnx.export`` writes ``nn.Mish`` as Softplus -> Tanh -> Mul, and ONNX Runtime's CPU
Softplus is an unvectorised loop: at the cpu preset's batch of 200 it alone took a fifth of the
exported U-Net's time. Written with one exponential instead (``n = e^x``,
``tanh(softplus(x)) = n(n + 2) / (n(n + 2) + 2)``), the same function runs as vectorised
element-wise operators. ``x`` is clipped at 20 inside the exponential, where the ratio is 1 in
float32, so that large inputs cannot overflow to inf / inf. In torch (training, inference) the
ordinary ``nn.Mish`` runs; the export's parity check (``scdp.policies.exported``) holds the two
forms to the same outputs.
"""

from __future__ import annotations

import torch
from torch import nn

EXP_CLIP = 20.0  # tanh(softplus(x)) == 1 in float32 above this


class Mish(nn.Mish):
    """``nn.Mish``, exported to ONNX in its one-exponential form."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not torch.onnx.is_in_onnx_export():
            return super().forward(x)
        n = torch.exp(torch.clamp(x, max=EXP_CLIP))
        p = n * (n + 2)
        return x * (p / (p + 2))  # the ratio first: x * p overflows for large x
