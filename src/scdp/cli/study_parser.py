"""The ``scdp study`` subcommands' arguments and help text (the rest of the parser: :mod:`scdp.cli.parser`).

Standard library and scdp's light leaves only, as the parser (ranges: :mod:`scdp.cli.types`), so ``scdp --help`` stays instant.
"""

from __future__ import annotations

from scdp.cli.parser_common import TASK_HELP
from scdp.cli.types import count, float_in, int_in, port, seed
from scdp.study.person import ParticipantModel
from scdp.study.power_settings import PowerSettings
from scdp.study.record import StudyConfig
from scdp.study.rules import Screening, flags_of

FLAG_TYPES = {"count": count, "seed": seed, "int_in": int_in, "float_in": float_in}  # what a field's flag names


def _flag_type(kind):
    """A field's flag type (scdp.study.rules.flag): a type, a name of :data:`FLAG_TYPES`, or a name with its bounds."""
    if isinstance(kind, tuple):
        name, *bounds = kind
        options = bounds.pop() if bounds and isinstance(bounds[-1], dict) else {}
        return FLAG_TYPES[name](*bounds, **options)
    return FLAG_TYPES.get(kind, kind)


def add_flags(p, cls) -> None:
    """Add the flag of each flagged field of ``cls`` (scdp.study.rules.flags_of): declared once, on the fields."""
    for name, keywords in flags_of(cls):
        p.add_argument(name, **{**keywords, "type": _flag_type(keywords["type"])})


def _make(ss) -> None:
    """``make``: its arguments and help."""
    p = ss.add_parser("make", help="roll the methods out on the study's scenes and write the study folder",
                      description="Scenes: --scenes ambiguous and --scenes clear ones from the study's own random stream "
                                  "(never the evaluation's) and a practice scene. Every method runs on every scene with the "
                                  "same noise; a Latin square assigns one method per scene to each participant, with a "
                                  "random mirror image, goal colours and goal order per trial. The checks are main trials "
                                  "(--attention graded by where the motion ends, --instructed told at its end which goal "
                                  "to choose), drawn per participant among the motions that end clearly at their target, "
                                  "so nothing before a motion's end tells a check apart. Every motion plays at one speed, "
                                  "as the robot executed it, the median main motion lasting --duration-s. Block Reach "
                                  "stimuli are frames from a person's view across the table (in frames/); Navigation "
                                  "stimuli are drawn from the path. Writes study.json: everything needed to serve and "
                                  "rerun it.")
    p.add_argument("--task", required=True, help=TASK_HELP)
    p.add_argument("--checkpoints", required=True, help="the trained model set (base/, ld/, encoder/, style_*/)")
    add_flags(p, StudyConfig)  # declared once, on the settings' fields (scdp.study.record)
    add_flags(p.add_argument_group("screening rules", "who the analysis leaves out, fixed in study.json before any data"),
              Screening)  # declared once, on the rules' fields (scdp.study.rules)
    p.add_argument("--out", required=True, help="the study folder to write")
    p.add_argument("--force", action="store_true", help="replace an existing study folder (and its responses)")
    p.set_defaults(handler="study:make")


def _serve(ss) -> None:
    """``serve``: its arguments and help."""
    p = ss.add_parser("serve", help="run the study's web page and store the answers",
                      description="Serves the page at / (participants arrive at /?pid=THEIR_ID, as crowdsourcing "
                                  "platforms pass it) and its JSON routes. Each confirmed trial is committed to the "
                                  "database before the page moves on; a refresh resumes where the participant was; a "
                                  "second answer to a trial is refused (409). Replace the placeholder consent text with "
                                  "consent.html in the study folder.")
    p.add_argument("--study", required=True, help="a folder written by scdp study make")
    p.add_argument("--database", help="SQLAlchemy URL (default: sqlite:///STUDY/responses.sqlite)")
    p.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--port", type=port, default=8000, help="TCP port (default 8000)")
    p.add_argument("--api-docs", action="store_true", help="also serve /docs, /redoc and /openapi.json (default off: "
                                                           "participants need none of them)")
    p.set_defaults(handler="study:serve")


def _analyze(ss) -> None:
    """``analyze``: its arguments and help."""
    p = ss.add_parser("analyze", help="curves, paired comparisons and a report from the stored answers",
                      description="Writes report.md, summary.json, responses.csv (every response) and accuracy.png into "
                                  "--out (default STUDY/analysis).")
    p.add_argument("--study", required=True, help="a folder written by scdp study make")
    p.add_argument("--database", help="SQLAlchemy URL (default: sqlite:///STUDY/responses.sqlite)")
    p.add_argument("--simulated", action="store_true",
                   help="analyse scdp study simulate's database (STUDY/simulated.sqlite) instead of people's")
    p.add_argument("--out", help="analysis folder (default STUDY/analysis)")
    p.add_argument("--seed", type=seed, default=0, help="bootstrap seed (default 0)")
    p.add_argument("--force", action="store_true", help="replace an existing analysis folder")
    p.set_defaults(handler="study:analyze")


def _simulate(ss) -> None:
    """``simulate``: its arguments and help."""
    p = ss.add_parser("simulate", help="simulated participants answer through the real page (headless Chromium)",
                      description="Starts the study's server on a free loopback port and runs --participants simulated "
                                  "observers (IDs SIM-001, ...) through the page in Debian's chromium: the project's "
                                  "path-length observer with noise on its beliefs and a reaction delay. The page runs on "
                                  "Playwright's fake clock, so the same --seed gives the same answers on any machine. "
                                  "For testing a study before people see it; its answers are labelled simulated in "
                                  "every report.")
    p.add_argument("--study", required=True, help="a folder written by scdp study make")
    p.add_argument("--database", help="SQLAlchemy URL (default: sqlite:///STUDY/simulated.sqlite, never people's database)")
    p.add_argument("--participants", type=int_in(1, 1000), default=30, help="how many (default 30)")
    add_flags(p, ParticipantModel)  # --noise, --delay-s (scdp.study.person)
    p.add_argument("--seed", type=seed, default=0, help="the participants' noise (default 0)")
    p.add_argument("--no-browser", action="store_true",
                   help="the same simulated person through the study's HTTP API instead of the page (the server's rules "
                        "all apply, the page is not exercised): about fifty times faster, for studies of the size "
                        "scdp study power recommends")
    p.set_defaults(handler="study_sim:simulate")


def _power(ss) -> None:
    """``power``: its arguments and help."""
    p = ss.add_parser("power", help="how many participants the study needs: simulated studies over its own design",
                      description="Simulates --replicates whole studies at each size of --participants, on the study's "
                                  "own stimuli, Latin square, targets, checks and screens, and analyses each with the "
                                  "crossed bootstrap: the power is the share whose 95 %% interval of A - B on --set "
                                  "excludes 0 in the claimed direction (A more legible). Answers come from the "
                                  "simulated person (--noise, --delay-s; what scdp study simulate puts through the "
                                  "page) or, with --pilot, from the study's analysed responses to each stimulus. "
                                  "Writes --out (markdown) and the same name with .json.")
    p.add_argument("--study", required=True, help="a folder written by scdp study make")
    add_flags(p, PowerSettings)  # --a, --b, --quantity, --set, --participants, ..., --seed (scdp.study.power_settings)
    p.add_argument("--pilot", action="store_true", help="answers drawn from the study database's analysed responses")
    p.add_argument("--database", help="with --pilot: SQLAlchemy URL (default: sqlite:///STUDY/responses.sqlite)")
    p.add_argument("--simulated", action="store_true", help="with --pilot: scdp study simulate's database instead")
    add_flags(p, ParticipantModel)  # --noise, --delay-s (scdp.study.person)
    p.add_argument("--out", required=True, help="the markdown report to write (its .json beside it)")
    p.add_argument("--force", action="store_true", help="replace an existing report")
    p.set_defaults(handler="study_power:run")


def _delete(ss) -> None:
    """``delete``: its arguments and help."""
    p = ss.add_parser("delete", help="remove one participant and every answer of theirs (a withdrawal)")
    p.add_argument("--study", required=True, help="a folder written by scdp study make")
    p.add_argument("--database", help="SQLAlchemy URL (default: sqlite:///STUDY/responses.sqlite)")
    p.add_argument("--participant", required=True, help="the participant's ID")
    p.set_defaults(handler="study:delete")


def add_study_parsers(sub) -> None:
    """``scdp study make | serve | analyze | simulate``."""
    study = sub.add_parser("study", help="an online observer study: make stimuli, serve the web page, analyse the answers",
                           description="People watch the robot move toward one of several goals and click the goal they "
                                       "believe, as early as they can, changing their mind at will. The workflow: "
                                       "(1) scdp study make rolls the methods out on the same scenes with the same noise "
                                       "and writes a study folder; (2) scdp study serve runs its web page (consent, "
                                       "instructions, a practice trial, the trials, a completion code), storing every "
                                       "confirmed answer in SQLite (or any SQLAlchemy URL); (3) scdp study analyze writes "
                                       "accuracy-over-time curves, paired method comparisons with a participant x scene "
                                       "bootstrap, and the project's observers on the same paths. scdp study simulate "
                                       "runs simulated participants through the real page (never human data).",
                           epilog="Example: scdp study make --task navigation --checkpoints runs/cpu/navigation/checkpoints "
                                  "--out runs/study; scdp study serve --study runs/study (send participants to "
                                  "http://HOST:8000/?pid=ID); scdp study analyze --study runs/study. docs/study.md covers "
                                  "consent, hosting, exporting and deleting data.")
    ss = study.add_subparsers(dest="study_command", metavar="<study command>",
                              parser_class=type(study))  # the one-line-error parser of scdp.cli.parser

    for add in (_make, _serve, _analyze, _simulate, _power, _delete):
        add(ss)
