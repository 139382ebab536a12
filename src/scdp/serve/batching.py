"""How ``scdp serve`` batches and sheds load (:class:`BatchingOptions`), light enough for the parser: each field
carries its flag (name, bounds, help), so the command line declares none of them again and
:class:`scdp.serve.batcher.DynamicBatcher` takes its defaults from here."""

from __future__ import annotations

from dataclasses import dataclass, field, fields


@dataclass(frozen=True)
class BatchingOptions:
    """At most ``max_batch`` requests per network call, the first waiting ``max_wait_ms`` for others, 503 beyond
    ``max_queue`` waiting or after ``timeout_s`` of waiting. Metadata: the flag, its accepted ``range`` (either end
    None: unbounded), and its help (:meth:`flags` adds the default)."""

    max_batch: int = field(default=64, metadata={"flag": "--max-batch", "range": (1, None),
                                                  "help": "most act requests in one network call"})
    max_wait_ms: float = field(default=5.0, metadata={
        "flag": "--max-wait-ms", "range": (0, 1000), "unit": "ms",
        "help": "how long the first waiting request waits for others to join its batch, in milliseconds, when the "
                "previous call served several requests (a lone client's request runs at once)"})
    max_queue: int = field(default=256, metadata={"flag": "--max-queue", "range": (1, None),
                                                  "help": "waiting requests beyond which new ones get 503"})
    timeout_s: float = field(default=10.0, metadata={
        "flag": "--timeout", "range": (0, 3600), "lo_open": True, "unit": "seconds",
        "help": "seconds a request may wait for the planner before it gets 503"})

    @classmethod
    def flags(cls) -> list:
        """Each field with its metadata: what a parser needs to add its flag (``dest`` is the field's name)."""
        return [(f.name, f.default, dict(f.metadata)) for f in fields(cls)]

    @classmethod
    def from_args(cls, args) -> BatchingOptions:
        """The options of a parsed command line (one attribute per field, as the parser adds them)."""
        return cls(**{f.name: getattr(args, f.name) for f in fields(cls)})
