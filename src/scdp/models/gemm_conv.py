"""The batch-1 speed path of the U-Net's convolutions: :class:`Conv1d` and :class:`ConvTranspose1d`.

When a plan is sampled for one trajectory, or a few, a wide convolution has only a handful of
output positions to apply its weights to, so what it costs is reading those weights, not the
arithmetic. Here such a convolution, at inference and with at most :data:`GEMM_POSITIONS`
positions, becomes a single matrix product: over the unfolded input windows for
:class:`Conv1d`, or producing every tap at once and then overlap-adding them for
:class:`ConvTranspose1d`. Each weight is read once, and a weight matrix above
:data:`SPLIT_BYTES` is split by output channel over torch's threads (:func:`_split_linear`)
so that the cores read it in parallel. For the paper preset's network at batch 1, torch's own
convolutions made a call take 38.5 ms against 21.8 ms on this path
(``results/benchmarks/plan_latency.md``, "conv as oneDNN").

In an ONNX export, :class:`Conv1d` is recorded as a 2-D convolution over a height of one:
ONNX Runtime's CPU provider runs 2-D convolutions in its channel-blocked layout and 1-D ones
through a per-sample path, and the exported U-Net's convolutions took 88 ms at a batch of 200
against 24 ms in the 2-D form (one thread, the cpu preset's Navigation network).

With autograd on (training), in an ONNX export, with more positions than that, or with an option this path does
not cover (string padding, dilation, groups, a padding mode other than zeros, an explicit
``output_size``), the ordinary ``torch.nn`` convolution runs. Both classes subclass the
``torch.nn`` modules and add no parameters or buffers, so their state-dict keys and weights
are those of ``nn.Conv1d`` and ``nn.ConvTranspose1d``.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import torch
import torch.nn.functional as F
from torch import nn

GEMM_POSITIONS = 64  # batch x length at or below which inference convolutions run as one GEMM
SPLIT_BYTES = 4 * 2**20  # weights above this are split across torch's threads in the GEMM path
_POOL: dict[int, ThreadPoolExecutor] = {}


def _split_linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
    """``F.linear`` with the output features split over torch's thread count, one GEMM per thread.

    A GEMM with a handful of rows is bound by reading the weights, and the BLAS runs it on one
    core; one slice of the weights per core reads them in parallel (``results/benchmarks/
    plan_latency.md``: the paper preset's call against the same net's oneDNN convolutions).
    Below :data:`SPLIT_BYTES`, or on one thread, it is plain ``F.linear``.
    """
    n = torch.get_num_threads()
    if n < 2 or weight.device.type != "cpu" or weight.numel() * weight.element_size() < SPLIT_BYTES:
        return F.linear(x, weight, bias)
    if n not in _POOL:  # one pool per thread count, made once
        _POOL[n] = ThreadPoolExecutor(n, thread_name_prefix="scdp-gemm")
    pool = _POOL[n]
    weights = weight.chunk(n)
    biases = bias.chunk(n) if bias is not None else [None] * n
    return torch.cat(list(pool.map(_linear_without_grad, [x] * n, weights, biases)), dim=-1)


def _linear_without_grad(x, weight, bias):
    with torch.no_grad():  # grad mode is per thread: the pool's threads do not inherit the caller's
        return F.linear(x, weight, bias)


def _plain() -> bool:
    """Whether torch's own convolution must run: training (autograd on), or an ONNX export, which
    records the graph of the ordinary operator (ONNX Runtime has its own fast convolution)."""
    return torch.is_grad_enabled() or torch.onnx.is_in_onnx_export()


class Conv1d(nn.Conv1d):
    """An ``nn.Conv1d`` (same weights, same result to float rounding) that, at inference with at
    most :data:`GEMM_POSITIONS` output positions, multiplies the unfolded input windows
    (B, T_out, C_in * K) by the weights (C_out, C_in * K) in one GEMM. Training, and large
    batches, where oneDNN's convolution is faster, take the ordinary path."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        B, C, T = x.shape
        if torch.onnx.is_in_onnx_export() and self.padding_mode == "zeros" and not isinstance(self.padding, str):
            return self._as_2d(x)
        if (_plain() or isinstance(self.padding, str) or self.dilation != (1,) or self.groups != 1
                or self.padding_mode != "zeros"):
            return super().forward(x)
        (k,), (pad,), (stride,) = self.kernel_size, self.padding, self.stride
        t_out = (T + 2 * pad - k) // stride + 1
        if B * t_out > GEMM_POSITIONS:
            return super().forward(x)
        windows = F.pad(x, (pad, pad)).unfold(2, k, stride)  # (B, C_in, T_out, K)
        windows = windows.permute(0, 2, 1, 3).reshape(B, t_out, C * k)
        return _split_linear(windows, self.weight.reshape(self.out_channels, C * k), self.bias).transpose(1, 2)  # (B, C_out, T_out)

    def _as_2d(self, x: torch.Tensor) -> torch.Tensor:
        """The same convolution as a 2-D one over a height of 1: (B, C_in, T) -> (B, C_out, T_out)."""
        (pad,), (stride,), (dilation,) = self.padding, self.stride, self.dilation
        out = F.conv2d(x.unsqueeze(2), self.weight.unsqueeze(2), self.bias, stride=(1, stride), padding=(0, pad),
                       dilation=(1, dilation), groups=self.groups)  # (B, C_out, 1, T_out)
        return out.squeeze(2)


class ConvTranspose1d(nn.ConvTranspose1d):
    """An ``nn.ConvTranspose1d`` that, at inference with at most :data:`GEMM_POSITIONS` input
    positions, computes every (output channel, tap) of every input position in one GEMM,
    (B, T, C_in) x (C_in, C_out * K), and overlap-adds the taps with ``F.fold`` (col2im).
    Elsewhere, the ordinary path."""

    def forward(self, x: torch.Tensor, output_size=None) -> torch.Tensor:
        B, C, T = x.shape
        if (_plain() or output_size is not None or B * T > GEMM_POSITIONS or self.groups != 1
                or self.dilation != (1,) or self.padding_mode != "zeros"):
            return super().forward(x, output_size)
        (k,), (stride,), (pad,), (extra,) = self.kernel_size, self.stride, self.padding, self.output_padding
        taps = _split_linear(x.transpose(1, 2), self.weight.reshape(C, -1).t(), None)  # (B, T, C_out * K)
        full = (T - 1) * stride + k + extra
        out = F.fold(taps.transpose(1, 2), output_size=(1, full), kernel_size=(1, k), stride=(1, stride))  # (B, C_out, 1, full)
        out = out[:, :, 0, pad:full - pad]  # (B, C_out, T_out)
        return out if self.bias is None else out + self.bias[:, None]
