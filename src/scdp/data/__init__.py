"""Demonstrations: Bézier generation, the zarr replay buffer, HDF5 import and style subsets.

The public names are loaded on first use, so ``import scdp.data`` stays light.
"""

_EXPORTS = {
    "DemoDataset": "scdp.data.dataset",
    "generate_demos": "scdp.data.generate",
    "import_robomimic": "scdp.data.robomimic",
    "style_subset": "scdp.data.subsets",
}

__all__ = list(_EXPORTS)


def __getattr__(name):
    if name in _EXPORTS:
        import importlib

        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'scdp.data' has no attribute {name!r}")
