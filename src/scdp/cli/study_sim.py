"""``scdp study simulate``: simulated participants through the study's real page (:mod:`scdp.study.participant`)."""

from __future__ import annotations

import time

from tqdm import tqdm

from scdp.study.make import read_study
from scdp.study.participant import ParticipantModel
from scdp.study.participant import simulate as run_simulated
from scdp.study.store import Store, database_url


def simulate(args) -> int:
    study = read_study(args.study)
    store = Store(database_url(args.study, args.database))
    model = ParticipantModel(noise=args.noise, delay_s=args.delay_s)
    start = time.perf_counter()
    with tqdm(total=args.participants, desc="simulated participants", unit="participant") as bar:
        run_simulated(study, args.study, store, args.participants, model=model, seed=args.seed,
                      progress=lambda n: bar.update(1))
    print(f"{args.participants} simulated participants answered ({(time.perf_counter() - start) / 60:.1f} min). "
          f"Next: scdp study analyze --study {args.study}")
    return 0
