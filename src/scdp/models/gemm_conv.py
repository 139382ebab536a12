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

At batch 1 a call is bound by how many operators it dispatches (on a GPU, one kernel launch
each), so the path is written in few of them: the windows are one strided view of the (padded)
input, copied once into the GEMM's rows; the weight matrix and the (B, C_out, T_out) result are
strided views, and a caller that normalises the result next (``contiguous=True``) gets it copied
into its contiguous layout in the same single operator. The GEMM itself is the very call
``F.linear`` would make on the unfolded windows (``addmm`` over contiguous rows; ``mm`` then the
bias where a pointwise convolution's windows are a transposed view of one sample, which
``matmul`` folds into one matrix; ``F.linear`` itself where it takes another path: frozen
weights, several samples), so the results are those of the plain formulation bit for bit.

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


def _splits(weight: torch.Tensor) -> bool:
    """Whether :func:`_split_linear` splits ``weight`` (large, on the CPU, with threads to split over)."""
    return (torch.get_num_threads() >= 2 and weight.device.type == "cpu"
            and weight.numel() * weight.element_size() >= SPLIT_BYTES)


def _split_linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None) -> torch.Tensor:
    """``F.linear`` with the output features split over torch's thread count, one GEMM per thread.

    A GEMM with a handful of rows is bound by reading the weights, and the BLAS runs it on one
    core; one slice of the weights per core reads them in parallel (``results/benchmarks/
    plan_latency.md``: the paper preset's call against the same net's oneDNN convolutions).
    Where :func:`_splits` says no (small weights, one thread, not the CPU), it is plain ``F.linear``.
    """
    if not _splits(weight):
        return F.linear(x, weight, bias)
    n = torch.get_num_threads()
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


def _is_contiguous(sizes, strides) -> bool:
    """Whether a strided view of these sizes and strides is contiguous (size-1 dimensions' strides aside)."""
    expected = 1
    for size, stride in zip(reversed(sizes), reversed(strides)):
        if size != 1 and stride != expected:
            return False
        expected *= size
    return True


def _transposed(weight: torch.Tensor, n: int) -> torch.Tensor:
    """A convolution's weight (W_0, ...) as the (n, W_0) matrix ``weight.reshape(W_0, n).t()``
    that ``F.linear`` multiplies by: one view when the weight is contiguous."""
    if not weight.is_contiguous():
        return weight.reshape(weight.shape[0], n).t()
    return weight.as_strided((n, weight.shape[0]), (1, n))


def _linear(rows: torch.Tensor, weight: torch.Tensor, n: int, bias: torch.Tensor | None) -> torch.Tensor:
    """``F.linear(rows, weight.reshape(W_0, n), bias)`` for a matrix ``rows`` (M, n), in the one
    call ``F.linear`` makes (``addmm``; ``mm`` without a bias), or split over the threads where
    :func:`_splits` says so."""
    if _splits(weight):
        return _split_linear(rows, weight.reshape(weight.shape[0], n), bias)
    weight_t = _transposed(weight, n)
    return torch.mm(rows, weight_t) if bias is None else torch.addmm(bias, rows, weight_t)


def _columns(rows: torch.Tensor, batch: int, contiguous: bool) -> torch.Tensor:
    """A GEMM's result ``rows`` (B * T_out, C_out) as (B, C_out, T_out): a strided view, or with
    ``contiguous`` a contiguous copy of it (one operator either way)."""
    t_out, c_out = rows.shape[0] // batch, rows.shape[1]
    size, stride = (batch, c_out, t_out), (t_out * c_out, 1, c_out)
    return torch.as_strided_copy(rows, size, stride) if contiguous else rows.as_strided(size, stride)


class Conv1d(nn.Conv1d):
    """An ``nn.Conv1d`` (same weights, same result to float rounding) that, at inference with at
    most :data:`GEMM_POSITIONS` output positions, multiplies the unfolded input windows
    (B, T_out, C_in * K) by the weights (C_out, C_in * K) in one GEMM. Training, and large
    batches, where oneDNN's convolution is faster, take the ordinary path.

    ``contiguous=True`` asks for a contiguous result (the GEMM path's is otherwise a transposed
    view of the GEMM's rows), made in the one copy a following normalisation would make anyway."""

    def forward(self, x: torch.Tensor, contiguous: bool = False) -> torch.Tensor:
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
        sb, sc, st = x.stride()
        if pad or not (_is_contiguous((B, C, T), (sb, sc, st)) or _is_contiguous((B, T, C), (sb, st, sc))):
            x = F.pad(x, (pad, pad))  # unpadded, a dense input is read in place, as F.pad's copy of it would be laid out
            sb, sc, st = x.stride()
        n = C * k
        size, strides = (B, t_out, C, k), (sb, stride * st, sc, st)  # the windows (B, T_out, C_in, K), a view of x
        if _is_contiguous(size, strides):  # already the GEMM's contiguous rows (a pointwise convolution's input)
            rows = _linear(x.as_strided((B * t_out, n), (n, 1)), self.weight, n, self.bias)
        elif not (k == 1 or C == 1 or sc == k * st):  # (C_in, K) do not flatten in place: one copy into the rows
            rows = _linear(torch.as_strided_copy(x, size, strides).view(B * t_out, n), self.weight, n, self.bias)
        elif B == 1 and self.weight.requires_grad and not _splits(self.weight):
            # the rows, a transposed matrix in place, which F.linear's matmul folds (B = 1) into one mm, bias after
            rows = torch.mm(x.as_strided((t_out, n), (stride * st, sc if k == 1 else st)), _transposed(self.weight, n))
            rows = rows if self.bias is None else rows.add_(self.bias)
        else:  # (B, T_out, C_in * K) in place, not one contiguous matrix: F.linear's matmul, as ever
            windows = x.as_strided(size, strides).reshape(B, t_out, n)
            return _split_linear(windows, self.weight.reshape(self.out_channels, n), self.bias).transpose(1, 2)
        return _columns(rows, B, contiguous)

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
        width = self.out_channels * k
        full = (T - 1) * stride + k + extra
        if B == 1 and self.weight.requires_grad:  # F.linear's matmul folds (T, C_in), a transposed view, into one mm
            _, sc, st = x.stride()
            rows, weight = x.as_strided((T, C), (st, sc)), self.weight.reshape(C, width)
            taps = _split_linear(rows, weight.t(), None) if _splits(self.weight) else torch.mm(rows, weight)
            taps = taps.as_strided((1, width, T), (T * width, 1, width))  # (1, C_out * K, T)
        else:
            taps = _split_linear(x.transpose(1, 2), self.weight.reshape(C, -1).t(), None).transpose(1, 2)
        out = F.fold(taps, output_size=(1, full), kernel_size=(1, k), stride=(1, stride))  # (B, C_out, 1, full)
        out = out.as_strided((B, self.out_channels, max(full - 2 * pad, 0)), (self.out_channels * full, full, 1),
                             out.storage_offset() + pad)  # (B, C_out, T_out): out[:, :, 0, pad:full - pad]
        return out if self.bias is None else out + self.bias.unsqueeze(1)
