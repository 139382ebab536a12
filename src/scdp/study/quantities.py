"""What one response of the study gives (:mod:`scdp.study.analysis` reads them, ``scdp study power``
simulates them): light, so the command line names them without the analysis stack."""

from __future__ import annotations

from scdp.observers import FRACTIONS

AT = FRACTIONS  # fractions of the motion where accuracy is read, as the observers' report reads them
AT_S = (1.0, 2.0, 3.0)  # seconds of motion: every motion plays at one speed, so a method's paths may last longer
QUANTITIES = ("final", "t_kept", "changes", "confidence", *(f"correct_at_{round(100 * f)}" for f in AT),
              *(f"correct_at_{s:g}s" for s in AT_S), "duration_s")
POWERED = tuple(q for q in QUANTITIES if q in ("final", "t_kept") or q.startswith("correct_at_"))  # read from the picks
LOWER_IS_BETTER = ("t_kept",)
