"""Demonstrations and what is computed from them.

``bezier`` (paths), ``scenes`` (every random scene and the six layouts), ``generate`` (Bézier
demos executed in simulation), ``dataset`` (the zarr replay buffer), ``robomimic`` (HDF5
import), ``reference`` (per-scene normalisation of D and E), ``subsets`` (style subsets),
``stats`` (what ``scdp inspect`` prints), ``windows`` (training batches) and ``normalizer``
(the policies' min-max scaling, fitted on those windows).
"""
