"""The planning service (``scdp serve``): FastAPI app and dynamic batching of planner calls."""
