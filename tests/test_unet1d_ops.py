"""The U-Net's inference call in operators (issue 49): a batch-1 call is bound by how many aten
operators it dispatches (on a GPU, about one kernel launch each), so they are counted here, for the
shipped network sizes; and its outputs are checked bit for bit against a plain functional
re-implementation of the network written below from the module's parameters.

The reference convolution is the layer's definition: torch's own convolution where the module
takes it (autograd on, or more than ``GEMM_POSITIONS`` output positions), else the input's unfolded
windows times the weight matrix in one ``F.linear`` (:mod:`scdp.models.gemm_conv`). The CPU's split
of large weights over threads is turned off here: it is not on a GPU's path, and the reference's
single GEMM is what the split is compared with, to rounding, in ``tests/test_gemm_conv.py``.
"""

import math

import pytest
import torch
import torch.nn.functional as F
from torch import nn
from torch.utils._python_dispatch import TorchDispatchMode

from scdp.models import gemm_conv
from scdp.models.film import Film
from scdp.presets import PRESETS
from scdp.tasks import NAVIGATION
from scdp.training.parts import build_diffusion

# aten operators one batch-1 call dispatches (torch.no_grad, 3-level U-Net, both sizes alike): at
# c7d85cb, before issue 49's rewrite, and now
OPS_BEFORE = {None: 578, "all": 628}
OPS_NOW = {None: 356, "all": 384}


@pytest.fixture(scope="module")
def nets():
    """``nets(size)``: the preset's network as the library builds it, made once for this module (the
    paper's has 65 M parameters)."""
    made = {}

    def net(size: str) -> nn.Module:
        if size not in made:
            made[size] = build_diffusion(NAVIGATION, PRESETS[size]).unet.eval()
        return made[size]

    yield net
    made.clear()


def _inputs(net, batch: int, film: str | None):
    g = torch.Generator().manual_seed(batch)
    cond_dim = net.down[0][0].film[1].in_features - net.step_embedding[0].dim
    x, k = torch.randn(batch, 16, net.final[1].out_channels, generator=g), torch.randint(0, 100, (batch,), generator=g)
    c = torch.randn(batch, cond_dim, generator=g)
    if film is None:
        return x, k, c, None
    width = net.film_width(film)
    return x, k, c, Film(1 + 0.3 * torch.randn(batch, width, generator=g), 0.2 * torch.randn(batch, width, generator=g), film)


class _Count(TorchDispatchMode):
    """Counts the aten operators dispatched while it is active (in this thread)."""

    def __init__(self):
        super().__init__()
        self.ops = 0

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        self.ops += 1
        return func(*args, **(kwargs or {}))


@pytest.fixture(autouse=True)
def _no_thread_split(monkeypatch):
    monkeypatch.setattr(gemm_conv, "SPLIT_BYTES", math.inf)


@pytest.mark.parametrize("film", [None, "all"])
@pytest.mark.parametrize("size", ["cpu", "paper"])
def test_a_batch_1_call_dispatches_at_least_30_percent_fewer_operators(nets, size, film):
    assert all(OPS_NOW[f] <= 0.7 * OPS_BEFORE[f] for f in OPS_BEFORE)  # issue 49's goal, on the stated counts
    net = nets(size)
    args = _inputs(net, 1, film)
    with torch.no_grad():
        with _Count() as count:
            net(*args)
    assert count.ops <= OPS_NOW[film], f"{count.ops} operators per call, {OPS_NOW[film]} stated ({OPS_BEFORE[film]} before)"


# -- the reference: the network written out plainly ------------------------------------------------

def _conv(conv: nn.Conv1d, x: torch.Tensor) -> torch.Tensor:
    (k,), (pad,), (stride,) = conv.kernel_size, conv.padding, conv.stride
    B, C, T = x.shape
    t_out = (T + 2 * pad - k) // stride + 1
    if torch.is_grad_enabled() or B * t_out > gemm_conv.GEMM_POSITIONS:
        return F.conv1d(x, conv.weight, conv.bias, stride=stride, padding=pad)
    windows = F.pad(x, (pad, pad)).unfold(2, k, stride).permute(0, 2, 1, 3).reshape(B, t_out, C * k)
    return F.linear(windows, conv.weight.reshape(conv.out_channels, C * k), conv.bias).transpose(1, 2)


def _conv_transpose(up: nn.ConvTranspose1d, x: torch.Tensor) -> torch.Tensor:
    (k,), (pad,), (stride,) = up.kernel_size, up.padding, up.stride
    B, C, T = x.shape
    if torch.is_grad_enabled() or B * T > gemm_conv.GEMM_POSITIONS:
        return F.conv_transpose1d(x, up.weight, up.bias, stride=stride, padding=pad)
    taps = F.linear(x.transpose(1, 2), up.weight.reshape(C, -1).t())  # (B, T, C_out * K)
    full = (T - 1) * stride + k
    out = F.fold(taps.transpose(1, 2), output_size=(1, full), kernel_size=(1, k), stride=(1, stride))
    return out[:, :, 0, pad:full - pad] + up.bias[:, None]


def _conv_block(block, x):
    conv, norm, _ = block.net
    return F.mish(F.group_norm(_conv(conv, x), norm.num_groups, norm.weight, norm.bias, norm.eps))


def _residual(block, x, cond, film):
    h = _conv_block(block.conv1, x)
    linear = block.film[1]
    scale, bias = F.linear(F.mish(cond), linear.weight, linear.bias)[:, :, None].chunk(2, dim=1)
    h = scale * h + bias
    if film is not None:
        h = film[0][:, :, None] * h + film[1][:, :, None]
    skip = x if isinstance(block.skip, nn.Identity) else _conv(block.skip, x)
    return _conv_block(block.conv2, h) + skip


def _reference(net, x, k, global_cond, film):
    embed, first, _, second = net.step_embedding
    half = embed.dim // 2
    angles = k.float()[:, None] * torch.exp(-math.log(10000.0) * torch.arange(half) / (half - 1))[None]
    step = F.linear(F.mish(F.linear(torch.cat([angles.sin(), angles.cos()], -1), first.weight, first.bias)),
                    second.weight, second.bias)
    cond = torch.cat([step, global_cond], dim=-1)
    blocks = [b for level in net.down for b in level[:2]] + list(net.mid) + [b for level in net.up for b in level[:2]]
    sizes = [b.conv1.net[0].out_channels for b in blocks]
    films = [None] * len(blocks)
    if film is not None and film.placement == "all":
        films = list(zip(film.gamma.split(sizes, dim=-1), film.beta.split(sizes, dim=-1)))
    elif film is not None:  # the first bottleneck block
        films[2 * len(net.down)] = (film.gamma, film.beta)
    films = iter(films)
    h, skips = x.transpose(1, 2), []
    for res1, res2, down in net.down:
        h = _residual(res2, _residual(res1, h, cond, next(films)), cond, next(films))
        skips.append(h)
        h = h if isinstance(down, nn.Identity) else _conv(down, h)
    h = _residual(net.mid[1], _residual(net.mid[0], h, cond, next(films)), cond, next(films))
    for res1, res2, up in net.up:
        h = _residual(res1, torch.cat([h, skips.pop()], dim=1), cond, next(films))
        h = _conv_transpose(up, _residual(res2, h, cond, next(films)))
    return _conv(net.final[1], _conv_block(net.final[0], h)).transpose(1, 2)


@pytest.mark.parametrize("size, batch, film, frozen", [
    ("cpu", 1, None, False), ("cpu", 1, "all", False), ("cpu", 1, "bottleneck", False),
    ("cpu", 2, "all", False),  # a planner's two styled predictions in one call
    ("cpu", 2, "all", True), ("cpu", 1, "all", True),  # parameters frozen (requires_grad off): matmul's own paths
    ("cpu", 200, None, False), ("cpu", 200, "all", False),  # torch's convolutions
    ("paper", 1, None, False), ("paper", 1, "all", False),
])
def test_inference_outputs_equal_the_plain_network_bit_for_bit(nets, size, batch, film, frozen):
    net = nets(size)
    args = _inputs(net, batch, film)
    try:
        net.requires_grad_(not frozen)
        with torch.no_grad():
            assert torch.equal(net(*args), _reference(net, *args))
    finally:
        net.requires_grad_(True)


def test_training_outputs_and_gradients_equal_the_plain_network_bit_for_bit(nets):
    """Autograd on: torch's convolutions, and every block's own Mish of the condition (one shared
    Mish would add the blocks' gradients in another order)."""
    net = nets("cpu")
    x, k, c, film = _inputs(net, 4, "all")
    grads = []
    for forward in (net, lambda *a: _reference(net, *a)):
        cond = c.clone().requires_grad_(True)
        gamma, beta = film.gamma.clone().requires_grad_(True), film.beta.clone().requires_grad_(True)
        out = forward(x, k, cond, Film(gamma, beta, "all"))
        net.zero_grad(set_to_none=True)
        (out * torch.linspace(-1, 1, out.numel()).view_as(out)).sum().backward()
        grads.append([out.detach(), cond.grad, gamma.grad, beta.grad, *(p.grad for p in net.parameters())])
    assert all(torch.equal(a, b) for a, b in zip(*grads))
