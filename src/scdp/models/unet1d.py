"""1-D conditional U-Net of the Diffusion Policy design, with a style hook in every block (or the bottleneck alone).

Notation: B batch, T horizon (a multiple of 4 when there are three levels), A action dim,
G global-condition dim, C channels.

    "bottleneck" (the paper's design):
    x (B, T, A) ──conv──▶ down path ──▶ mid (bottleneck, C_last x T/4) ──▶ up path ──▶ ε (B, T, A)
                                          ▲ h ← γ ⊙ h + β, film (γ, β) each (B, C_last)

    "all" (both shipped presets, cpu and paper):
    x ──▶ [down blocks] ──▶ [mid blocks] ──▶ [up blocks] ──▶ ε
            ▲ γ_i, β_i        ▲ γ_i, β_i      ▲ γ_i, β_i     film (γ, β) each (B, ΣC_i), one slice per block

Every residual block is FiLM-conditioned on ``[diffusion-step embedding, global condition]``
as ``scale * h + bias``, (scale, bias) = Linear(Mish(condition)); at inference the Mish, the same
for every block, is computed once per call (with autograd on, each block computes its own, so that
the gradients add up as they always have). The *style* modulation is separate: an optional
:class:`~scdp.models.film.Film` ``(γ, β, placement)``, its placement named by its maker (never
inferred from its width) and placed by :class:`scdp.models.film.FilmLayout` (:attr:`ConditionalUnet1D.film_layout`, the
one home of its widths and slices):

* ``"bottleneck"``: ``C_last`` wide, inside the first bottleneck block only (the paper's design);
* ``"all"``: the sum of every residual block's width, one slice per block, in forward order (an
  option of this library, which both presets use: the up path also reads the unmodulated skips of
  the down path, which a bottleneck-only shift cannot reach).

With ``film=None`` (or γ = 1, β = 0) the network computes exactly its base function.

The inference speed path of its convolutions (one GEMM each at batch 1) lives in
:mod:`scdp.models.gemm_conv`. At batch 1 a call is bound by the number of operators it dispatches
(a GPU's kernel launches), so the forward pass is written in few: the step embedding's frequencies
are a buffer, the style film is sliced into per-block columns in one pass
(:meth:`~scdp.models.film.FilmLayout.slices`), and each conv block asks its convolution for the
contiguous result its group norm reads. Every such change computes the same numbers as before, bit
for bit (on the CPU; see :class:`SinusoidalStepEmbedding` for a GPU); ``tests/test_unet1d_ops.py``
counts the operators and checks the outputs against a plain re-implementation.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from scdp.models.film import FilmLayout
from scdp.models.gemm_conv import Conv1d, ConvTranspose1d
from scdp.models.mish import Mish


class SinusoidalStepEmbedding(nn.Module):
    """Diffusion step k (B,) -> (B, dim) sin/cos features at geometric frequencies.

    The frequencies (1, dim / 2) are a non-persistent buffer (not in the state dict), made once on
    the CPU by the expression each call used to evaluate, so the same numbers on the CPU. On a GPU
    they are these, moved; each call used to compute them there, with the GPU's ``exp``, which may
    differ in the last bit."""

    def __init__(self, dim: int):
        super().__init__()
        self.dim = dim
        half = dim // 2
        self.register_buffer("freqs", torch.exp(-math.log(10000.0) * torch.arange(half) / (half - 1))[None],
                             persistent=False)

    def forward(self, k: torch.Tensor) -> torch.Tensor:
        angles = k.float()[:, None] * self.freqs
        return torch.cat([angles.sin(), angles.cos()], dim=-1)


class ConvBlock(nn.Module):
    """Conv1d -> GroupNorm -> Mish. (B, C_in, T) -> (B, C_out, T)."""

    def __init__(self, c_in: int, c_out: int, kernel: int, groups: int):
        super().__init__()
        self.net = nn.Sequential(Conv1d(c_in, c_out, kernel, padding=kernel // 2), nn.GroupNorm(groups, c_out), Mish())

    def forward(self, x):
        conv, norm, act = self.net
        return act(norm(conv(x, contiguous=True)))  # the group norm reads a contiguous input


class ResidualBlock(nn.Module):
    """Two conv blocks with FiLM ``scale * h + bias`` from the condition between them.

    x (B, C_in, T), cond (B, D) -> (B, C_out, T). ``film`` = (γ, β), each (B, C_out, 1) (a
    column of :meth:`~scdp.models.film.FilmLayout.slices`), is applied after the condition's FiLM
    when given. (scale, bias) = ``self.film(cond)`` = Linear(Mish(cond)); with ``activated`` the
    caller passes Mish(cond) itself (the U-Net at inference, which computes it once for every block).
    """

    def __init__(self, c_in: int, c_out: int, cond_dim: int, kernel: int, groups: int):
        super().__init__()
        self.conv1 = ConvBlock(c_in, c_out, kernel, groups)
        self.conv2 = ConvBlock(c_out, c_out, kernel, groups)
        self.film = nn.Sequential(Mish(), nn.Linear(cond_dim, 2 * c_out))
        self.skip = Conv1d(c_in, c_out, 1) if c_in != c_out else nn.Identity()

    def forward(self, x, cond, film=None, activated: bool = False):
        h = self.conv1(x)
        scale, bias = self.film[1](cond if activated else self.film[0](cond)).unsqueeze(-1).chunk(2, dim=1)
        h = scale * h + bias
        if film is not None:
            gamma, beta = film
            h = gamma * h + beta
        return self.conv2(h) + self.skip(x)


class ConditionalUnet1D(nn.Module):
    """ε-prediction network. ``forward(x (B,T,A), k (B,), global_cond (B,G), film) -> (B,T,A)``."""

    def __init__(self, action_dim: int, global_cond_dim: int, down_dims=(256, 512, 1024),
                 step_embed_dim: int = 256, kernel_size: int = 5, n_groups: int = 8):
        super().__init__()
        dims = [action_dim, *down_dims]
        cond_dim = step_embed_dim + global_cond_dim
        self.step_embedding = nn.Sequential(
            SinusoidalStepEmbedding(step_embed_dim),
            nn.Linear(step_embed_dim, 4 * step_embed_dim), Mish(),
            nn.Linear(4 * step_embed_dim, step_embed_dim),
        )
        block = lambda i, o: ResidualBlock(i, o, cond_dim, kernel_size, n_groups)  # noqa: E731
        levels = list(zip(dims[:-1], dims[1:]))
        self.down = nn.ModuleList()
        for n, (c_in, c_out) in enumerate(levels):
            last = n == len(levels) - 1
            self.down.append(nn.ModuleList([block(c_in, c_out), block(c_out, c_out),
                                            nn.Identity() if last else Conv1d(c_out, c_out, 3, stride=2, padding=1)]))
        mid = down_dims[-1]
        self.mid = nn.ModuleList([block(mid, mid), block(mid, mid)])
        self.up = nn.ModuleList()
        for c_in, c_out in reversed(levels[1:]):  # each level undoes one downsampling
            self.up.append(nn.ModuleList([block(2 * c_out, c_in), block(c_in, c_in),
                                          ConvTranspose1d(c_in, c_in, 4, stride=2, padding=1)]))
        self.final = nn.Sequential(ConvBlock(down_dims[0], down_dims[0], kernel_size, n_groups), Conv1d(down_dims[0], action_dim, 1))
        self.condition_mish = Mish()  # every block's film[0], applied once per call at inference (no parameters)
        self.bottleneck_dim = mid
        blocks = self._blocks()
        self.film_layout = FilmLayout(tuple(b.conv1.net[0].out_channels for b in blocks), blocks.index(self.mid[0]))

    def _blocks(self) -> list[ResidualBlock]:
        """Every residual block in forward order."""
        down = [b for res1, res2, _ in self.down for b in (res1, res2)]
        up = [b for res1, res2, _ in self.up for b in (res1, res2)]
        return down + list(self.mid) + up

    def film_channels(self, blocks: str) -> list[int]:
        """Widths of the style film's slices: ``"bottleneck"`` -> [C_last]; ``"all"`` -> every block's."""
        return self.film_layout.channels(blocks)

    def film_width(self, blocks: str) -> int:
        """Width of γ (and β) a style predictor must give to film ``blocks``."""
        return self.film_layout.width(blocks)

    def forward(self, x: torch.Tensor, k: torch.Tensor, global_cond: torch.Tensor, film=None) -> torch.Tensor:
        """x (B,T,A), k (B,) int, global_cond (B,G), film None or a Film (γ, β each (B, W), placement):
        W = C_last for ``"bottleneck"``, the sum of every block's width for ``"all"`` (checked)."""
        cond = torch.cat([self.step_embedding(k), global_cond], dim=-1)
        # the blocks' Mish of the condition, once for all of them at inference; with autograd on, each
        # block's own (one backward per block, summed into cond's gradient as always)
        activated = not torch.is_grad_enabled()
        cond = self.condition_mish(cond) if activated else cond
        films = iter(self.film_layout.slices(film))
        h = x.transpose(1, 2)  # (B, A, T)
        skips = []
        for res1, res2, downsample in self.down:
            h = res1(h, cond, next(films), activated)
            h = res2(h, cond, next(films), activated)
            skips.append(h)
            h = downsample(h)
        h = self.mid[0](h, cond, next(films), activated)  # (B, C_last, T/4): the paper's only style hook
        h = self.mid[1](h, cond, next(films), activated)
        for res1, res2, upsample in self.up:
            h = torch.cat([h, skips.pop()], dim=1)  # the first level's skip is not used
            h = res1(h, cond, next(films), activated)
            h = upsample(res2(h, cond, next(films), activated))
        return self.final(h).transpose(1, 2)


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())
