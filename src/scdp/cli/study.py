"""``scdp study make | serve | analyze | delete`` (see :mod:`scdp.study`); ``simulate`` lives in
:mod:`scdp.cli.study_sim`, the one part that needs a browser."""

from __future__ import annotations

import time
from pathlib import Path

from scdp.serve.listen import resolve, serve_app
from scdp.study.app import create_app
from scdp.study.make import make_study, read_study
from scdp.study.record import MAIN, StudyConfig
from scdp.study.report import write_analysis
from scdp.study.store import DATABASE_FILE, SIMULATED_FILE, Store, database_url
from scdp.tasks import get_task


def make(args) -> int:
    config = StudyConfig.from_args(args)
    start = time.perf_counter()
    study = make_study(get_task(args.task), args.checkpoints, args.out, config, force=args.force,
                       command=args.command_line)
    trials = len(study.ids(MAIN))
    checks = (f"{config.attention} attention and {config.instructed} instructed-response check"
              + ("s" if config.attention + config.instructed != 1 else ""))
    print(f"wrote {args.out}: {study.task}, {study.goals} goals, {len(config.methods)} methods x "
          f"{2 * config.scenes_per_set} scenes ({trials} stimuli), a practice and {checks} "
          f"({(time.perf_counter() - start) / 60:.1f} min); codes: finished {study.config.completion_code}, declined "
          f"{study.config.declined_code}, screened out {study.config.screened_code}. "
          f"Next: scdp study serve --study {args.out}")
    return 0


def serve(args) -> int:
    study = read_study(args.study)
    resolve(args.host, args.port)
    store = Store(database_url(args.study, args.database))
    banner = (f"serving the {study.task} study {args.study} at {{url}}/?pid=PARTICIPANT_ID "
              f"(answers: {store.engine.url.render_as_string(hide_password=True)})")
    app = create_app(study, args.study, store, api_docs=args.api_docs)
    return serve_app(app, args.host, args.port, banner, "put it behind HTTPS (docs/study.md)")


def analyze(args) -> int:
    study = read_study(args.study)
    start = time.perf_counter()
    out = Path(args.out) if args.out else Path(args.study) / "analysis"
    store = Store(database_url(args.study, args.database, file=SIMULATED_FILE if args.simulated else DATABASE_FILE))
    summary = write_analysis(study, store.participants(), store.rows(), out, command=args.command_line,
                             ratings=store.ratings(),
                             force=args.force, seed=args.seed, minutes_so_far=(time.perf_counter() - start) / 60)
    data = {"simulated": "SIMULATED data", "mixed": "a MIXED database (simulated participants left out)",
            "people": "people"}[summary["data"]]
    print(f"wrote {out}: {data}; {summary['participants']} consented, {summary['analysed_participants']} analysed, "
          f"{len(summary['excluded'])} excluded with their reasons, {summary['responses']} responses "
          "(report.md, summary.json, responses.csv, participants.csv, accuracy.png)")
    return 0


def delete(args) -> int:
    read_study(args.study)
    n = Store(database_url(args.study, args.database)).delete(args.participant)
    print(f"deleted participant {args.participant} and {n} responses")
    return 0
