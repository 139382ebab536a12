"""Tests of scdp.models.gemm_conv: the convolutions run as GEMMs at inference, against torch's own."""

import pytest
import torch
import torch.nn.functional as F

from helpers.floats import float32_network_bound, float32_sum_bound
from helpers.tiny import _unet


def _accumulations(net: torch.nn.Module) -> tuple[int, int]:
    """The longest sum of products one output of a layer takes, and how many such layers the net has."""
    layers = [m for m in net.modules() if isinstance(m, (torch.nn.Conv1d, torch.nn.ConvTranspose1d, torch.nn.Linear))]
    longest = max(m.in_features if isinstance(m, torch.nn.Linear) else m.in_channels * m.kernel_size[0]
                  for m in layers)
    return longest, len(layers)


def test_inference_convolutions_as_one_gemm_match_the_convolution(monkeypatch):
    """Few positions at inference take the GEMM path (Conv1d); its result is the convolution's."""
    from scdp.models import gemm_conv

    net = _unet()
    calls = []
    real_pad = gemm_conv.F.pad  # only the GEMM path pads by hand (the convolution pads inside)
    monkeypatch.setattr(gemm_conv.F, "pad", lambda *a, **kw: calls.append(1) or real_pad(*a, **kw))
    x, k, c = torch.randn(1, 16, 3), torch.tensor([7]), torch.randn(1, 10)
    with torch.no_grad():
        fast = net(x, k, c)
    assert calls, "batch 1 at inference should run the convolutions as GEMMs"
    with torch.enable_grad():  # training path: oneDNN convolution, no GEMM
        calls.clear()
        slow = net(x, k, c)
        assert not calls
    longest, layers = _accumulations(net)
    bound = float32_network_bound(longest, layers) * slow.abs().max().item()
    gap = (fast - slow.detach()).abs().max().item()
    assert gap <= bound, f"GEMM path {gap:.2e} from the convolution, float32 rounding allows {bound:.2e}"
    assert bound < 1e-3  # the bound is far below what a wrong convolution gives (an O(1) error)
    with torch.no_grad():  # above GEMM_POSITIONS positions even at the deepest level (T/4): the convolution
        calls.clear()
        b = gemm_conv.GEMM_POSITIONS // 4 + 1
        net(torch.randn(b, 16, 3), torch.tensor([7] * b), torch.randn(b, 10))
        assert not calls


@pytest.mark.parametrize("stride, padding, extra", [(2, 1, 0), (2, 1, 1), (3, 0, 2), (1, 2, 0)])
def test_gemm_convolutions_match_torch_for_strides_and_paddings(stride, padding, extra):
    """The GEMM paths of Conv1d (unfold) and ConvTranspose1d (fold) against torch's own operators."""
    from scdp.models.gemm_conv import Conv1d, ConvTranspose1d

    torch.manual_seed(1)
    x = torch.randn(2, 6, 9)
    conv = Conv1d(6, 5, 3, stride=stride, padding=padding)
    up = ConvTranspose1d(6, 5, 4, stride=stride, padding=padding, output_padding=extra)
    with torch.no_grad():
        # elementwise, within the worst case of two float32 sums of C_in x K products in any order:
        # 2 gamma_n x (|W| * |x|), the convolution of the magnitudes computed in float64
        for ours, theirs in ((conv, F.conv1d), (up, F.conv_transpose1d)):
            options = dict(stride=stride, padding=padding, **({"output_padding": extra} if ours is up else {}))
            magnitude = theirs(x.double().abs(), ours.weight.double().abs(), ours.bias.double().abs(), **options)
            n = ours.in_channels * ours.kernel_size[0] + 1  # and the bias
            gap = (ours(x) - theirs(x, ours.weight, ours.bias, **options)).double().abs()
            assert (gap <= 2 * float32_sum_bound(n) * magnitude).all(), f"largest gap {gap.max():.2e}"


def test_large_weights_split_over_threads_give_the_same_output(monkeypatch):
    """The GEMM path's per-thread split of the output channels (large nets at batch 1) changes nothing."""
    from scdp.models import gemm_conv

    net = _unet()
    x, k, c = torch.randn(1, 16, 3), torch.tensor([7]), torch.randn(1, 10)
    with torch.no_grad():
        whole = net(x, k, c)
    threads = torch.get_num_threads()
    monkeypatch.setattr(gemm_conv, "SPLIT_BYTES", 0)  # split every weight
    monkeypatch.setattr(gemm_conv, "_POOL", {})
    try:
        torch.set_num_threads(3)  # more slices than cores is fine; 3 does not divide every width
        with torch.no_grad():
            split = net(x, k, c)
    finally:
        torch.set_num_threads(threads)
    assert 3 in gemm_conv._POOL  # the split ran
    gap, bound = (split - whole).abs().max().item(), float32_network_bound(*_accumulations(net)) * whole.abs().max().item()
    assert gap <= bound, f"the split output {gap:.2e} from the whole one, float32 rounding allows {bound:.2e}"
