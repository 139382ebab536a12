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

import torch

PLACEMENTS = ("bottleneck", "all")


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

    def placement_of(self, width: int) -> str:
        """The placement a film of ``width`` has (the two widths differ for any U-Net of two or more levels)."""
        if width == self.bottleneck_dim:
            return "bottleneck"
        if width == self.width("all"):
            return "all"
        raise ValueError(f"a style film of width {width} fits neither the bottleneck ({self.bottleneck_dim}) "
                         f"nor every block ({self.width('all')})")

    def slices(self, film) -> list:
        """Per-block (γ, β) or None, in forward order, of ``film`` (None: every block unmodulated)."""
        if film is None:
            return [None] * len(self.sizes)
        if self.placement_of(film[0].shape[-1]) == "bottleneck":
            return [film if i == self.bottleneck_index else None for i in range(len(self.sizes))]
        return list(zip(film[0].split(list(self.sizes), dim=-1), film[1].split(list(self.sizes), dim=-1)))

    def full(self, film, batch: int) -> tuple[torch.Tensor, torch.Tensor]:
        """(γ, β) of every block's width, float32 on the CPU, from ``film`` (None, bottleneck-only or full):
        what an exported graph, which always takes the full width, is fed."""
        width = self.width("all")
        gamma, beta = torch.ones(batch, width), torch.zeros(batch, width)
        if film is None:
            return gamma, beta
        if self.placement_of(film[0].shape[-1]) == "all":
            return film[0].float().cpu(), film[1].float().cpu()
        at = slice(self.bottleneck_offset, self.bottleneck_offset + self.bottleneck_dim)
        gamma[:, at], beta[:, at] = film[0].float().cpu(), film[1].float().cpu()
        return gamma, beta

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
