"""Demonstrations and what is computed from them.

``bezier`` (paths), ``scenes`` (every random scene and the six layouts), ``generate`` (Bézier
demos executed in simulation), ``dataset`` (the zarr replay buffer), ``robomimic`` (HDF5
import), ``stats`` (what ``scdp inspect`` prints), ``windows`` (training batches) and
``normalizer`` (the policies' min-max scaling, fitted on those windows). Scoring paths against
per-scene reference curves, and the style subsets ranked by those scores, are the layer above
(:mod:`scdp.scoring`).
"""
