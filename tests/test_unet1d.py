"""Tests of scdp.models.unet1d: the conditional U-Net, its shapes and its FiLM (identity, every block)."""

import pytest
import torch

from helpers.tiny import _unet
from scdp.models.film import Film


def test_film_identity_gives_exactly_the_base_output():
    net = _unet()
    x, k, c = torch.randn(4, 16, 3), torch.tensor([0, 5, 50, 99]), torch.randn(4, 10)
    ones, zeros = torch.ones(4, 32), torch.zeros(4, 32)
    with torch.no_grad():
        assert torch.equal(net(x, k, c), net(x, k, c, Film(ones, zeros, "bottleneck")))
        assert not torch.allclose(net(x, k, c), net(x, k, c, Film(ones * 1.5, zeros + 0.2, "bottleneck")))


def test_film_on_every_block_touches_the_up_path_and_its_width_picks_the_blocks():
    net = _unet()
    sizes = net.film_channels("all")
    assert net.film_channels("bottleneck") == [32] and sizes == [8, 8, 16, 16, 32, 32, 32, 32, 16, 16, 8, 8]
    x, k, c = torch.randn(2, 16, 3), torch.tensor([3, 40]), torch.randn(2, 10)
    W = sum(sizes)
    with torch.no_grad():
        base = net(x, k, c)
        assert torch.equal(base, net(x, k, c, Film(torch.ones(2, W), torch.zeros(2, W), "all")))
        # a shift in the last block's slice only (the up path) moves the output
        beta = torch.zeros(2, W)
        beta[:, -8:] = 0.5
        assert not torch.allclose(base, net(x, k, c, Film(torch.ones(2, W), beta, "all")))
        # the placement is the film's own word, never read off its width: a full-width film
        # named "bottleneck" is refused, as is a width that fits its placement nowhere
        with pytest.raises(ValueError, match="'bottleneck' film has width 32 in this U-Net, got 224"):
            net(x, k, c, Film(torch.ones(2, W), torch.zeros(2, W), "bottleneck"))
        with pytest.raises(ValueError, match="'all' film has width 224"):
            net(x, k, c, Film(torch.ones(2, 32), torch.zeros(2, 32), "all"))
        with pytest.raises(ValueError, match="placement must be one of"):
            net(x, k, c, Film(torch.ones(2, W), torch.zeros(2, W), "up"))


def test_unet_shapes_and_bottleneck():
    net = _unet()
    assert net.bottleneck_dim == 32
    assert net(torch.randn(2, 16, 3), torch.tensor([1, 2]), torch.randn(2, 10)).shape == (2, 16, 3)
