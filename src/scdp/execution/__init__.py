"""From planned joint waypoints to a moving arm at 1 kHz: :func:`interpolate`, the chunk-by-chunk
:class:`JerkLimitedStreamer`, the limit check and the :class:`Arm` interface (docs/deploy.md)."""

from scdp.execution.arm import Arm, SimulatedPanda, tracking_error
from scdp.execution.interpolate import PANDA_LIMITS, JerkLimitedStreamer, JointLimits, Samples, interpolate, limit_ratios, violations

__all__ = ["Arm", "SimulatedPanda", "tracking_error", "PANDA_LIMITS", "JerkLimitedStreamer", "JointLimits", "Samples",
           "interpolate", "limit_ratios", "violations"]
