"""``scdp serve``: the planning service over HTTP (see :mod:`scdp.serve.app`).

Everything that can fail is done before the "serving" line: the options are checked, ``--host``
is resolved, every served planner is loaded and verified (:class:`~scdp.serve.app.PlanningService`),
and the listening socket is bound (:mod:`scdp.serve.listen`). A failure in any of them is the usual one-line error with exit
status 2, never a "serving" line followed by uvicorn's log.
"""

from __future__ import annotations

from scdp.config import PlanningOptions
from scdp.devices import describe
from scdp.serve.app import PlanningService, create_app
from scdp.serve.batcher import BatchingOptions
from scdp.serve.listen import resolve, serve_app


def serve(args) -> int:  # the flags' ranges are checked as they are parsed (scdp.cli.types)
    resolve(args.host, args.port)  # a typo in --host is reported before minutes of loading
    service = PlanningService(args.checkpoints, args.task, methods=args.methods, batching=BatchingOptions.from_args(args),
                              planning=PlanningOptions.from_args(args))
    for note in service.notes:
        print(f"scdp: warning: {note}")
    banner = (f"serving {service.task.name} ({', '.join(service.methods)}) from {args.checkpoints} on "
              f"{describe(service.device)}, {{url}} (OpenAPI: /docs, /openapi.json)")
    return serve_app(create_app(service), args.host, args.port, banner, "the service has no authentication")
