"""Comparing numbers recomputed now with the ones a committed file stores, on any processor.

A float computed on this machine and the same float stored by another can differ in their last
bits: numpy, OpenBLAS and oneDNN pick their SIMD kernels (AVX-512, AVX2, SSE) per processor, and
a wider kernel adds in another order. So a recomputation is compared with what it stored

* for full-precision floats, within ``REL`` relative or ``ABS`` absolute (:func:`close`). The
  recomputed quantities are sums and means of at most ~10^5 float64 terms of order one (metrics of
  a path, paired differences, bootstrap percentiles of means); the unit roundoff is 1.1e-16, so the
  worst-case error of such a sum is ~10^5 x 1.1e-16 ~ 1e-11 of the terms' magnitude, and the
  observed differences are a few ulps (2e-16 relative). ``REL = 1e-9`` leaves two orders of
  magnitude above the worst case and still catches any change in what is computed; ``ABS = 1e-12``
  covers differences of means that are near zero, whose relative error is unbounded;
* for numbers printed rounded (a table's ``0.45``, a claim's ``0.503``), exactly, or one unit in
  their last printed place apart: a value within 1e-13 of a rounding boundary may round either way
  (:func:`close_printed`). The full-precision numbers beside them in ``claims.json`` and the
  records pin what was computed;
* everything that is not a number (words, keys, true/false, the order of lines), identically.

Tests that compare two results of the same process on the same machine (the same command twice,
killed and resumed) stay exact; they do not use this module.
"""

from __future__ import annotations

import json
import math
import re

REL = 1e-9
ABS = 1e-12
ROUNDED_DECIMALS = 4  # a printed number with at most this many decimals was rounded on purpose
NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def close(got: float, want: float) -> bool:
    return math.isclose(got, want, rel_tol=REL, abs_tol=ABS)


def _decimals(text: str) -> int | None:
    """Decimals of a plainly printed number (``"0.503"`` -> 3); None in exponent form."""
    if "e" in text.lower():
        return None
    return len(text.split(".")[1]) if "." in text else 0


def close_printed(got: str, want: str) -> bool:
    """Two printed numbers are the same number: identical, within :func:`close`, or, when printed
    rounded, adjacent in their last place (``"0.125"`` and ``"0.124"``, ``"-0.000"`` and ``"0.000"``)."""
    if got == want:
        return True
    a, b = float(got), float(want)
    if close(a, b):
        return True
    places = [d for d in (_decimals(got), _decimals(want)) if d is not None]
    if len(places) < 2 or max(places) > ROUNDED_DECIMALS:
        return False
    unit = 10.0 ** -max(places)
    return abs(a - b) <= unit * (1 + 1e-9)


def mismatches(got, want, path: str = "$") -> list[str]:
    """Where two parsed JSON trees differ beyond float rounding (empty when they agree)."""
    if isinstance(want, bool) or isinstance(got, bool) or want is None or isinstance(want, str):
        return [] if got == want and type(got) is type(want) else [f"{path}: {got!r} != {want!r}"]
    if isinstance(want, (int, float)):
        if not isinstance(got, (int, float)):
            return [f"{path}: {got!r} != {want!r}"]
        if isinstance(want, int) and isinstance(got, int):
            return [] if got == want else [f"{path}: {got} != {want}"]
        return [] if close_printed(repr(float(got)), repr(float(want))) else [f"{path}: {got!r} != {want!r}"]
    if isinstance(want, dict):
        if not isinstance(got, dict) or list(got) != list(want):
            return [f"{path}: keys {list(got) if isinstance(got, dict) else type(got).__name__} != {list(want)}"]
        return [m for k in want for m in mismatches(got[k], want[k], f"{path}.{k}")]
    if isinstance(want, (list, tuple)):
        if not isinstance(got, (list, tuple)) or len(got) != len(want):
            return [f"{path}: {got!r} != {want!r}"]
        return [m for i, (g, w) in enumerate(zip(got, want)) for m in mismatches(g, w, f"{path}[{i}]")]
    raise TypeError(f"{path}: cannot compare {type(want).__name__}")


def text_mismatches(got: str, want: str) -> list[str]:
    """Where two texts differ: any character outside a number, or a number by more than :func:`close_printed` allows."""
    got_words, want_words = NUMBER.split(got), NUMBER.split(want)
    got_numbers, want_numbers = NUMBER.findall(got), NUMBER.findall(want)
    if got_words != want_words or len(got_numbers) != len(want_numbers):
        line = next((i for i, (g, w) in enumerate(zip(got.splitlines(), want.splitlines())) if
                     NUMBER.split(g) != NUMBER.split(w)), min(len(got.splitlines()), len(want.splitlines())))
        return [f"text differs at line {line + 1}"]
    return [f"number {i}: {g} != {w}" for i, (g, w) in enumerate(zip(got_numbers, want_numbers))
            if not close_printed(g, w)]


def file_mismatches(got: str, want: str, name: str) -> list[str]:
    """A rebuilt file against the committed one: JSON as parsed trees, any other text by :func:`text_mismatches`."""
    if name.endswith(".json"):
        return mismatches(json.loads(got), json.loads(want))
    return text_mismatches(got, want)


# -- two float32 implementations of the same arithmetic ----------------------------------------------
# A float32 sum of n products is within gamma_n = n u / (1 - n u) of the exact sum, relative to the
# sum of the products' magnitudes (u = 2^-24, the unit roundoff; Higham, Accuracy and Stability of
# Numerical Algorithms, section 3.1), whatever order a kernel adds in; two kernels that add in
# different orders are therefore within 2 gamma_n of each other. Through a network of many such
# layers the worst case compounds far beyond what happens; rounding errors of random sign grow like
# sqrt(n) u instead (Higham and Mary, 2019), which is the bound used for a whole network.
FLOAT32_UNIT_ROUNDOFF = 2.0**-24


def float32_sum_bound(n: int) -> float:
    """gamma_n for float32: the worst-case relative error of a sum of ``n`` products."""
    nu = n * FLOAT32_UNIT_ROUNDOFF
    return nu / (1 - nu)


def float32_network_bound(longest_sum: int, layers: int) -> float:
    """How far two float32 evaluations of a network may lie apart, relative to its output's scale:
    ``layers`` accumulating layers in sequence, each adding at most ``longest_sum`` products, each
    contributing a rounding error of order sqrt(n) u, in both evaluations (x 2)."""
    return 2 * layers * math.sqrt(longest_sum) * FLOAT32_UNIT_ROUNDOFF
