"""A simulated participant that takes a study through its real web page, in headless Chromium.

It is the project's Bayesian observer (:func:`scdp.metrics.observer_posterior`, the path-length
observer) with the imperfections of a person: it looks at the motion every ``look_s`` seconds,
acts on what it saw ``delay_s`` ago (a reaction time), perturbs its belief with Gaussian noise
on each goal's log probability, drawn once per trial (a misjudgement of the scene that persists
while the motion plays, so it changes its mind only when the motion itself argues for it), and clicks the goal it then believes most likely
whenever that goal changes (with ``commit`` > 0, only once its belief reaches ``commit``); it reads
the instructions (it answers the comprehension check rightly), follows an instruction shown at a
motion's end, gives its confidence from its final belief, and rates the motions at the end from
what it saw (:meth:`ParticipantModel.rate`). The
project's observer metrics read the same arg-max (:func:`scdp.observers.correct_at`). It never knows the target: the page does not have it,
and the observer scales path costs by the mean start-to-goal distance rather than the target's.
It reads what is on the screen from the page's ``window.study`` (the goals and the path drawn so
far, in task space) and answers by clicking the page's buttons (Start, the goals, Confirm), so the
page, the server and the database are exercised exactly as a person would. The page runs on
Playwright's fake clock and the server on a :class:`VirtualClock` advanced with it, so the server's
timing rules (the motion served no faster than it plays, no Confirm before its end) hold for a
simulated participant exactly as for a person, and a run takes far less than its motions' time. Used by the tests and by ``scdp study simulate``;
its participants' IDs start with :data:`SIMULATED_PREFIX`, and nothing they produce is human data.
"""  # noqa: E501 (docstring text kept byte-identical)

from __future__ import annotations

import threading
import time
import zlib

import numpy as np
import uvicorn
from playwright.sync_api import Page, sync_playwright

from scdp.errors import ScdpError
from scdp.serve.listen import bind
from scdp.study import questions
from scdp.study.app import create_app
from scdp.study.design import SIMULATED_PREFIX
from scdp.study.person import ParticipantModel
from scdp.study.record import Study

CHROMIUM = "/usr/bin/chromium"  # Debian's chromium package
POLL_MS = 10  # real milliseconds between two reads of the page while waiting for it


class VirtualClock:
    """The server's clock for simulated participants: seconds that pass only when :meth:`advance` says."""

    def __init__(self, start: float | None = None):
        self.now = time.time() if start is None else float(start)  # real timestamps in the database
        self._lock = threading.Lock()

    def __call__(self) -> float:
        with self._lock:
            return self.now

    def advance(self, seconds: float) -> None:
        with self._lock:
            self.now += float(seconds)


class ServerThread:
    """A uvicorn server of ``app`` on a free loopback port, in a thread (``with ServerThread(app) as url``)."""

    def __init__(self, app, host: str = "127.0.0.1"):
        self.server = uvicorn.Server(uvicorn.Config(app, log_level="warning"))
        sock = bind(host, 0)  # the service's socket (TCP_NODELAY on every connection: scdp.serve.listen)
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [sock]}, daemon=True)

    def __enter__(self) -> str:
        self.thread.start()
        while not self.server.started:
            if not self.thread.is_alive():
                raise ScdpError("server", "the study server did not start")
            time.sleep(0.01)
        host, port = self.server.servers[0].sockets[0].getsockname()[:2]
        return f"http://{host}:{port}"

    def __exit__(self, *exc):
        self.server.should_exit = True
        self.thread.join(timeout=10)


def launch_browser(playwright):
    """Headless Debian Chromium (one line naming the package when it is missing)."""
    try:
        return playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
    except Exception as exc:  # noqa: BLE001 - Playwright raises its own Error for a missing or broken browser
        raise ScdpError("browser", f"cannot start {CHROMIUM} ({str(exc).splitlines()[0]}); install Debian's "
                                   "chromium package") from None


def screen(page: Page) -> dict:
    return page.evaluate("window.study")


def wait_screen(page: Page, names, after_index=None, timeout_s: float = 30.0) -> dict:
    """Wait until the page shows one of ``names`` (and, for a trial, a trial after ``after_index``)."""
    page.wait_for_function(
        "([names, after]) => names.includes(window.study.screen) && "
        "(window.study.screen !== 'trial' || after === null || window.study.index > after)",
        arg=[list(names), after_index], polling=POLL_MS, timeout=timeout_s * 1000)
    return screen(page)


def settle(page: Page, timeout_s: float = 30.0) -> None:
    """Wait until none of the page's calls is in flight (a poll for more of the motion, a pick), so that what
    the page has when the clocks next move does not depend on how fast the server answered."""
    page.wait_for_function("window.study.calls === 0", polling=POLL_MS, timeout=timeout_s * 1000)


def click_goal(page: Page, goal: int) -> None:
    """Click goal button ``goal`` and wait for the server's answer to the pick, so the server stamps it at
    the look that made it: the clocks move only between looks (never while a pick is on its way)."""
    with page.expect_response(lambda r: r.url.endswith("/api/pick"), timeout=30_000):
        page.click(f"#goal-{goal}", no_wait_after=True)


def take_trial(page: Page, model: ParticipantModel, rng: np.random.Generator, clock: VirtualClock) -> int:
    """Press Start, watch one trial, clicking goals as the model decides, then confirm; returns the
    position (on the page) of the confirmed goal.

    The page runs on Playwright's fake clock, paused, and the server on ``clock``: each look advances
    both by ``look_s`` of motion (animation frames and all), and a click waits for the server's answer
    before the next look (:func:`click_goal`), so what the participant sees, when it clicks and when the
    server stamps the click do not depend on how busy the machine is: a participant's answers and
    timings follow from its seed alone."""
    s = screen(page)
    if not s["started"]:
        page.click("#start", no_wait_after=True)
    wait_playing(page)  # clicks before the motion plays do not count
    index, picked, looks = screen(page)["index"], screen(page)["picked"], []
    offsets = model.noise * rng.standard_normal(len(screen(page)["goals"]))  # this trial's misjudgement
    step, elapsed, end = max(1, round(1000 * model.look_s)), 0.0, None
    while end is None or elapsed < end + model.delay_s - 1e-9:  # it reacts to the motion's end too, delay_s later
        clock.advance(step / 1000)
        page.clock.run_for(step)
        settle(page)
        elapsed += step / 1000
        s = screen(page)
        looks.append((elapsed, s["shown"], s["done"]))
        seen = [(shown, done) for when, shown, done in looks if when <= elapsed - model.delay_s + 1e-9]
        if seen:  # nothing is clicked before a look at least delay_s old: a person reacts to what they saw
            k = model.decide(*seen[-1][:1], s["goals"], offsets, picked, ended=seen[-1][1])
            if k is not None:
                click_goal(page, k)
                picked = k
        if s["done"] and end is None:
            end = elapsed
    if picked is None:  # never sure enough: the best guess at the end
        picked = int(np.argmax(model.belief(screen(page)["shown"], screen(page)["goals"])))
        click_goal(page, picked)
    s = screen(page)
    if s["note"]:  # an instruction: it is followed
        told = [k for k, name in enumerate(s["colours"]) if f"the {name} goal" in s["note"]]
        if told and told[0] != picked:
            clock.advance(model.look_s)  # a person's time to read it (and the server's pick interval)
            page.clock.run_for(max(1, round(1000 * model.look_s)))
            picked = told[0]
            click_goal(page, picked)
    page.check(f"#confidence-{model.confidence(model.noisy(model.belief(s['shown'], s['goals']), offsets))}")
    clock.advance(model.confirm_s)  # a person's time to press Confirm, as the screening rules expect
    page.clock.run_for(max(1, round(1000 * model.confirm_s)))
    page.click("#confirm", no_wait_after=True)
    s = wait_screen(page, ("trial", "feedback", "ratings", "done", "error"), after_index=index)
    if s["screen"] == "feedback":
        page.click("#feedback-go", no_wait_after=True)
        wait_screen(page, ("trial", "ratings", "done", "error"), after_index=index)
    return picked


def take_ratings(page: Page, model: ParticipantModel) -> None:
    """Rate every motion shown at the end, then finish."""
    for i, item in enumerate(screen(page)["items"]):
        for name, value in model.rate(item["motion"]["path"], item["trial"]["goals"]).items():
            page.check(f"#{name}-{i}-{value}")
    page.click("#ratings-go", no_wait_after=True)
    wait_screen(page, ("done", "error"))


def wait_playing(page: Page, timeout_s: float = 30.0) -> None:
    page.wait_for_function("window.study.playing", polling=POLL_MS, timeout=timeout_s * 1000)


def run_participant(url: str, pid: str, model: ParticipantModel, seed: int, *, browser,
                    clock: VirtualClock) -> str:
    """One participant from the link to the completion code (returned)."""
    rng = np.random.default_rng(seed)
    context = browser.new_context(viewport={"width": 800, "height": 900})
    context.clock.install(time=0)
    context.clock.pause_at(1000)  # the page's time moves only when take_trial looks
    page = context.new_page()
    try:
        page.goto(f"{url}/?pid={pid}")
        s = wait_screen(page, ("consent", "instructions", "trial", "done", "error"))
        if s["screen"] == "consent":
            page.check("#consent-box")
            page.click("#consent-go")
            s = wait_screen(page, ("instructions", "trial", "done", "error"))
        if s["screen"] == "instructions":
            for i, answer in enumerate(questions.ANSWERS):  # it has read the instructions
                page.check(f"#q{i}-{answer}")
            page.click("#instructions-go")
            s = wait_screen(page, ("trial", "error"))
        while s["screen"] == "trial":
            take_trial(page, model, rng, clock)
            s = screen(page)
        if s["screen"] == "ratings":
            take_ratings(page, model)
            s = screen(page)
        if s["screen"] != "done":
            raise ScdpError("page", f"{pid} ended on the {s['screen']} screen: {page.text_content('#error-text')}")
        return page.text_content("#done-code")
    finally:
        context.close()


def simulate(study: Study, folder, store, count: int, *, model: ParticipantModel = ParticipantModel(),
             seed: int = 0, progress=None) -> list[str]:
    """``count`` simulated participants (IDs ``SIM-001``...) through the study's page, served from
    ``folder`` over ``store`` on a :class:`VirtualClock`; their completion codes."""
    clock = VirtualClock()
    codes = []
    with ServerThread(create_app(study, folder, store, clock=clock)) as url, sync_playwright() as pw:
        browser = launch_browser(pw)
        try:
            for i in range(count):
                own_seed = int(np.random.SeedSequence([zlib.crc32(b"simulated-participant"), seed, i]).generate_state(1)[0])
                codes.append(run_participant(url, f"{SIMULATED_PREFIX}{i + 1:03d}", model, own_seed,
                                             browser=browser, clock=clock))
                if progress:
                    progress(i + 1)
        finally:
            browser.close()
    return codes
