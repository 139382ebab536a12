"""``scdp study simulate``: simulated participants through the study's real page (:mod:`scdp.study.participant`)."""

from __future__ import annotations

import time

from tqdm import tqdm

from scdp.study import api_participant, participant
from scdp.study.make import read_study
from scdp.study.person import ParticipantModel
from scdp.study.rules import values_of
from scdp.study.store import SIMULATED_FILE, Store, database_url


def simulate(args) -> int:
    study = read_study(args.study)
    store = Store(database_url(args.study, args.database, file=SIMULATED_FILE))  # never the live database by default
    model = ParticipantModel(**values_of(ParticipantModel, args))
    start = time.perf_counter()
    with tqdm(total=args.participants, desc="simulated participants", unit="participant") as bar:
        run = api_participant.simulate if args.no_browser else participant.simulate
        run(study, args.study, store, args.participants, model=model, seed=args.seed, progress=lambda n: bar.update(1))
    how = "through the API, no browser" if args.no_browser else "through the page in Chromium"
    print(f"{args.participants} simulated participants answered {how} ({(time.perf_counter() - start) / 60:.1f} min). "
          f"(answers: {store.engine.url.render_as_string(hide_password=True)}). Next: scdp study analyze --study "
          f"{args.study} --database {store.engine.url.render_as_string(hide_password=True)}")
    return 0
