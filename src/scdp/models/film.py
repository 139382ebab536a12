"""Where a style film acts in the U-Net: the one home of its widths, offsets and slicing.

A style film is a pair (γ, β), each (B, W). The U-Net's residual blocks, in forward order (down
path, the two bottleneck blocks, up path), each have a width C_i. Two placements exist:

    "bottleneck"  W = C_last: the first bottleneck block only (the paper's design)
    "all"         W = sum of every C_i: one slice per block, in forward order (both shipped presets)

:class:`FilmLayout` is built by the U-Net (:attr:`scdp.models.unet1d.ConditionalUnet1D.film_layout`)
and stored with an exported graph (``onnx.json``'s ``film``), so the torch network, the exported
one and the loaders all read the same numbers.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import torch

PLACEMENTS = ("bottleneck", "all")


class Film(NamedTuple):
    """A style film: γ and β, each (B, W), and the placement they are for (one of :data:`PLACEMENTS`).

    The placement travels with the tensors, so no reader guesses it from W. A style predictor
    makes one (its ``StyleConfig.film_blocks``); the U-Net checks W against its layout."""

    gamma: torch.Tensor
    beta: torch.Tensor
    placement: str

    @staticmethod
    def identity(batch: int, width: int, placement: str, device=None) -> "Film":
        """γ = 1, β = 0: the base function exactly."""
        return Film(torch.ones(batch, width, device=device), torch.zeros(batch, width, device=device), placement)


@dataclass(frozen=True)
class FilmLayout:
    """Widths of every residual block in forward order, and the index of the first bottleneck block."""

    sizes: tuple[int, ...]
    bottleneck_index: int

    @property
    def bottleneck_dim(self) -> int:
        return self.sizes[self.bottleneck_index]

    @property
    def bottleneck_offset(self) -> int:
        """Where the bottleneck's slice starts in a full-width film."""
        return sum(self.sizes[:self.bottleneck_index])

    def channels(self, placement: str) -> list[int]:
        """Widths of the film's slices for ``placement``."""
        if placement == "bottleneck":
            return [self.bottleneck_dim]
        if placement == "all":
            return list(self.sizes)
        raise ValueError(f"film blocks must be 'bottleneck' or 'all', got {placement!r}")

    def width(self, placement: str) -> int:
        """Width of γ (and β) a style predictor must give for ``placement``."""
        return sum(self.channels(placement))

    def check(self, film: Film) -> Film:
        """``film`` itself, after checking that its width is its placement's in this U-Net."""
        if film.placement not in PLACEMENTS:
            raise ValueError(f"film placement must be one of {PLACEMENTS}, got {film.placement!r}")
        want = self.width(film.placement)
        if film.gamma.shape[-1] != want or film.beta.shape[-1] != want:
            raise ValueError(f"a {film.placement!r} film has width {want} in this U-Net, got "
                             f"{film.gamma.shape[-1]} (gamma) and {film.beta.shape[-1]} (beta)")
        return film

    def slices(self, film: Film | None) -> list:
        """Per-block (γ, β) or None, in forward order, of ``film`` (None: every block unmodulated);
        each of γ, β (B, C_i, 1), a column that broadcasts over the block's (B, C_i, T) activations
        (the film's (B, W) is given its trailing axis once, then split: views, no copies)."""
        if film is None:
            return [None] * len(self.sizes)
        gamma, beta, placement = self.check(film)
        gamma, beta = gamma.unsqueeze(-1), beta.unsqueeze(-1)
        if placement == "bottleneck":
            return [(gamma, beta) if i == self.bottleneck_index else None for i in range(len(self.sizes))]
        return list(zip(gamma.split(list(self.sizes), dim=-2), beta.split(list(self.sizes), dim=-2)))

    def full(self, film: Film | None, batch: int) -> tuple[torch.Tensor, torch.Tensor]:
        """(γ, β) of every block's width, float32 on the CPU, from ``film`` (None, bottleneck-only or full):
        what an exported graph, which always takes the full width, is fed."""
        if film is None:
            return Film.identity(batch, self.width("all"), "all")[:2]
        gamma, beta, placement = self.check(film)
        if placement == "all":
            return gamma.float().cpu(), beta.float().cpu()
        full_gamma, full_beta, _ = Film.identity(batch, self.width("all"), "all")
        at = slice(self.bottleneck_offset, self.bottleneck_offset + self.bottleneck_dim)
        full_gamma[:, at], full_beta[:, at] = gamma.float().cpu(), beta.float().cpu()
        return full_gamma, full_beta

    def to_dict(self) -> dict:
        """The record stored with an exported graph (with the derived numbers, for a reader)."""
        return {**asdict(self), "sizes": list(self.sizes), "width": self.width("all"),
                "bottleneck_offset": self.bottleneck_offset, "bottleneck_dim": self.bottleneck_dim}

    @staticmethod
    def from_dict(record: dict) -> "FilmLayout":
        if "bottleneck_index" in record:
            return FilmLayout(tuple(record["sizes"]), int(record["bottleneck_index"]))
        # graphs exported before the index was stored: find the block where the bottleneck's slice starts
        starts = [sum(record["sizes"][:i]) for i in range(len(record["sizes"]))]
        return FilmLayout(tuple(record["sizes"]), starts.index(record["bottleneck_offset"]))
