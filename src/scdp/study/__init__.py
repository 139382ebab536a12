"""``scdp study``: an online observer study, from paired trajectories to analysed predictions (docs/study.md)."""
