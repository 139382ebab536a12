"""Evaluation: batched rollouts in the simulator and the metrics of what was executed."""
