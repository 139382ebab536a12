"""``scdp serve``: the planning service over HTTP (see :mod:`scdp.serve.app`)."""

from __future__ import annotations

import uvicorn

from scdp.devices import describe
from scdp.errors import ScdpError
from scdp.serve.app import PlanningService, create_app


def serve(args) -> int:
    if not 0 <= args.port <= 65535:
        raise ScdpError("--port", f"must be 0..65535, got {args.port}")
    for name in ("max_batch", "max_queue"):
        if getattr(args, name) < 1:
            raise ScdpError("--" + name.replace("_", "-"), f"must be >= 1, got {getattr(args, name)}")
    if not 0 <= args.max_wait_ms <= 1000:
        raise ScdpError("--max-wait-ms", f"must be 0..1000, got {args.max_wait_ms}")
    if not args.timeout > 0:
        raise ScdpError("--timeout", f"must be > 0, got {args.timeout}")
    service = PlanningService(args.checkpoints, args.task, max_batch=args.max_batch, max_wait_ms=args.max_wait_ms,
                              max_queue=args.max_queue, timeout_s=args.timeout, sampler=args.sampler, steps=args.steps,
                              device=args.device)
    if args.host not in ("127.0.0.1", "localhost", "::1"):
        print(f"scdp: warning: listening on {args.host}, beyond this machine; the service has no authentication")
    print(f"serving {service.task.name} from {args.checkpoints} on {describe(service.device)}, http://{args.host}:{args.port} "
          f"(OpenAPI: /docs, /openapi.json)", flush=True)
    uvicorn.run(create_app(service), host=args.host, port=args.port, log_level="warning")
    return 0
