"""The study's page in a real browser (Debian's chromium): a person's trials, hints, Start, a reload
that resumes, Back, the retry state across a server restart, the redirect; simulated participants."""

import csv
import json
import socket
import subprocess
import sys
import time

import httpx
from playwright.sync_api import sync_playwright

from helpers.studies import synthetic_study
from scdp.cli import main
from scdp.study import questions
from scdp.study.make import read_study
from scdp.study.participant import ParticipantModel, launch_browser, simulate, wait_screen
from scdp.study.store import Store, database_url

HINT = "window.study.hint"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(folder, port):
    """``scdp study serve`` in its own process (so it can be stopped and started again)."""
    proc = subprocess.Popen([sys.executable, "-m", "scdp", "study", "serve", "--study", str(folder), "--port", str(port)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert "serving" in proc.stdout.readline()
    for _ in range(500):
        try:
            httpx.get(f"http://127.0.0.1:{port}/", timeout=1)
            return proc
        except httpx.TransportError:
            time.sleep(0.02)
    raise AssertionError("the server did not answer")


def play_and_answer(page, goal: int, index: int):
    """Press Start on trial ``index``, pick ``goal`` while it plays, wait for its end."""
    s = wait_screen(page, ("trial",), after_index=index - 1)
    assert s["index"] == index and page.evaluate(HINT) == "ready" and page.is_visible("#start")
    assert page.is_hidden("#confirm")
    page.click("#start")
    page.wait_for_function("window.study.playing")
    assert page.evaluate(HINT) == "playing"
    page.click(f"#goal-{goal}")
    page.wait_for_function("window.study.done")
    assert page.evaluate(HINT) == "ended" and page.is_disabled("#confirm")  # how sure, first
    page.check("#confidence-3")
    assert page.is_enabled("#confirm")


def comprehension(page, answers=questions.ANSWERS):
    """Answer the comprehension check after the instructions."""
    wait_screen(page, ("instructions",))
    assert page.is_disabled("#instructions-go")
    for i, answer in enumerate(answers):
        page.check(f"#q{i}-{answer}")
    page.click("#instructions-go")


def test_a_person_sees_start_hints_resume_retry_and_the_redirect(tmp_path):
    folder = tmp_path / "s"
    study = synthetic_study(folder, completion_url="https://example.org/done?cc={code}", duration_s=1.5)
    port = _free_port()
    proc = start_server(folder, port)
    try:
        with sync_playwright() as pw:
            browser = launch_browser(pw)
            page = browser.new_page(viewport={"width": 390, "height": 844})  # a phone
            page.route("https://example.org/**", lambda route: route.fulfill(body="back on the platform"))
            page.goto(f"http://127.0.0.1:{port}/?pid=bad id!")
            wait_screen(page, ("error",))
            assert "cannot be used here" in page.text_content("#error-text")
            assert "A-Za-z" not in page.text_content("#error-text")  # a sentence, not a pattern
            page.goto(f"http://127.0.0.1:{port}/?pid=alice&rate=0.25")
            wait_screen(page, ("consent",))
            page.check("#consent-box")
            page.click("#consent-go")
            comprehension(page, [(a + 1) % 3 for a in questions.ANSWERS])  # wrong once: read again, one try left
            page.wait_for_function("!document.getElementById('comprehension-retry').hidden")
            assert "1 attempt left" in page.text_content("#comprehension-retry")
            comprehension(page)
            play_and_answer(page, 0, 0)
            page.click("#confirm")
            # the practice's feedback names the goal the robot went to
            wait_screen(page, ("feedback",))
            assert page.text_content("#feedback-title") in ("Correct!", "Not quite")
            assert "goal" in page.text_content("#feedback-text")
            page.click("#feedback-go")
            # trial 1: the hint is reset; a reload while it plays resumes the motion, never restarts it
            wait_screen(page, ("trial",), after_index=0)
            assert page.evaluate(HINT) == "ready"
            page.click("#start")
            page.wait_for_function("window.study.t > 0.3")
            before = page.evaluate("window.study.t")
            page.reload()
            page.wait_for_function("window.study.playing && window.study.index === 1")
            assert page.evaluate(HINT) == "resumed" and page.is_hidden("#start")
            assert page.evaluate("window.study.t") >= before - 0.05
            page.click("#goal-1")
            page.wait_for_function("window.study.done")
            page.check("#confidence-5")
            page.click("#confirm")
            # Back stays on the study and says why
            wait_screen(page, ("trial",), after_index=1)
            page.go_back()
            assert page.is_visible("#no-back") and page.evaluate("window.study.screen") == "trial"
            # trial 2: the server stops before Confirm; the page shows it is retrying, then carries on
            play_and_answer(page, 0, 2)
            proc.terminate()
            proc.wait()
            page.click("#confirm")
            page.wait_for_function("window.study.offline")
            assert page.is_visible("#offline")
            proc = start_server(folder, port)
            wait_screen(page, ("trial",), after_index=2)
            assert page.is_hidden("#offline")
            index = 3
            while page.evaluate("window.study.screen") == "trial":
                play_and_answer(page, 0, index)
                if page.evaluate("window.study.note"):  # the instructed check says so at the motion's end
                    assert page.is_visible("#note") and "whatever the robot did" in page.text_content("#note")
                page.click("#confirm")
                page.wait_for_function(f"window.study.screen === 'ratings' || window.study.index > {index}")
                index += 1
            # the ratings: one motion per method, drawn in full, two 7-point statements each
            items = page.evaluate("window.study.items")
            assert len(items) == 2 and page.is_disabled("#ratings-go")
            for i in range(len(items)):
                page.check(f"#legible-{i}-6")
                page.check(f"#predictable-{i}-3")
            page.clock.install()  # the page's timers from here on run on a clock the test moves
            page.click("#ratings-go")
            wait_screen(page, ("done",))
            assert page.text_content("#done-code") == "DONE42" and page.is_visible("#debrief")
            page.clock.run_for(60_000)  # a minute on the page's clock: no timer takes the participant away
            assert page.url.startswith(f"http://127.0.0.1:{port}/") and page.is_visible("#debrief")
            page.click("#done-return")  # the participant leaves when they choose to
            page.wait_for_url("https://example.org/done?cc=DONE42", timeout=15_000)
            browser.close()
    finally:
        proc.terminate()
        proc.wait()
    rows = Store(database_url(folder)).rows()
    assert [r["trial"] for r in rows] == list(range(index)) and all(r["pid"] == "alice" for r in rows)
    assert rows[1]["replays"] >= 1 and rows[0]["replays"] == 0  # the reload is on record
    for r in rows:  # timed by the server: never before the motion could have been seen at rate 1
        assert r["confirmed"] - r["played"] >= study.config.duration_s - 0.05


def test_simulated_participants_answer_through_the_page_and_are_analysed(tmp_path):
    # a reaction-free participant picks before a person could: screened out as early under the default rule,
    # so this study pre-registers no such rule (the rule's own test is in test_study_screening.py)
    synthetic_study(tmp_path / "s", screening={"min_first_pick_s": 0.0})
    study = read_study(tmp_path / "s")
    store = Store(database_url(tmp_path / "s"))
    codes = simulate(study, tmp_path / "s", store, 2, model=ParticipantModel(noise=0.0, delay_s=0.0, look_s=0.02))
    assert codes == ["DONE42"] * 2
    rows = store.rows()
    assert {r["pid"] for r in rows} == {"SIM-001", "SIM-002"}
    assert all(r["confirmed"] - r["played"] >= 1.0 for r in rows)  # the server's rules held for them too
    assert main(["study", "analyze", "--study", str(tmp_path / "s"), "--out", str(tmp_path / "a")]) == 0
    summary = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert summary["data"] == "simulated" and summary["analysed_participants"] == 2, summary["excluded"]
    assert (tmp_path / "a" / "report.md").read_text().startswith("# SIMULATED DATA")
    # a noiseless participant without delay is the path-length observer (up to how often it looks)
    gaps = [v["gap_to_path_length_observer"] for b in summary["sets"].values() for v in b["methods"].values()]
    assert len(gaps) == 4 and max(gaps) < 0.1, gaps
    assert main(["study", "delete", "--study", str(tmp_path / "s"), "--participant", "SIM-002"]) == 0
    assert {r["pid"] for r in store.rows()} == {"SIM-001"}


def _click(page, goal: int) -> int:
    """Click goal button ``goal``; the status of the /api/pick call it made."""
    with page.expect_response(lambda r: r.url.endswith("/api/pick")) as answer:
        page.click(f"#goal-{goal}")
    page.wait_for_function("window.study.calls === 0")  # the page has handled the answer (a refusal too)
    return answer.value.status


def test_a_click_after_the_end_is_taken_on_every_stimulus_and_a_refused_one_leaves_the_page_usable(tmp_path):
    """Motions of 1.169716 s and 1.299684 s: to the millisecond, each end rounds *up* (1.170, 1.300), past what
    the server sent; a page that rounded its pick time so was refused on every such stimulus and died (issue 75).
    Every trial here (the practice and both checks included) is answered only after its motion ended, the
    instructed check as told; one quick second click is refused (429) and the page carries on."""
    folder = tmp_path / "s"
    # picks 1 s apart (the most a study allows): the quick second click below is refused however slowly a loaded machine runs the page
    study = synthetic_study(folder, duration_s=1.2347, points={"dp": 37, "scdp": 41}, pick_interval_s=1.0)
    durations = {study.motion_s(sid) for sid in study.stimuli}
    assert len(durations) == 2 and all(round(d * 1e3) / 1e3 > d for d in durations)
    port = _free_port()
    proc = start_server(folder, port)
    try:
        with sync_playwright() as pw:
            browser = launch_browser(pw)
            page = browser.new_page(viewport={"width": 1280, "height": 800})
            page.goto(f"http://127.0.0.1:{port}/?pid=late")
            wait_screen(page, ("consent",))
            page.check("#consent-box")
            page.click("#consent-go")
            comprehension(page)
            index, told = 0, 0
            while wait_screen(page, ("trial", "ratings"), after_index=index - 1)["screen"] == "trial":
                page.click("#start")
                page.wait_for_function("window.study.done")  # the motion has ended before any click
                note = page.evaluate("window.study.note")
                goal = 0
                if note:  # the instructed check: the goal it names
                    goal = next(k for k, name in enumerate(page.evaluate("window.study.colours")) if f"the {name} goal" in note)
                    told += 1
                assert _click(page, goal) == 200
                assert page.evaluate("window.study.screen") == "trial" and page.evaluate("window.study.picked") == goal
                if index == 1:  # a second click faster than a person clicks: refused, said so, the first stands
                    assert _click(page, 1) == 429
                    assert page.evaluate("window.study.screen") == "trial" and page.evaluate("window.study.picked") == 0
                    assert page.is_visible("#pick-refused") and "earlier choice stands" in page.text_content("#pick-refused")
                    page.wait_for_timeout(1000 * study.config.pick_interval_s + 50)
                    assert _click(page, 1) == 200 and page.is_hidden("#pick-refused")
                page.check("#confidence-4")
                page.click("#confirm")
                if wait_screen(page, ("trial", "feedback", "ratings"), after_index=index)["screen"] == "feedback":
                    page.click("#feedback-go")
                index += 1
            browser.close()
    finally:
        proc.terminate()
        proc.wait()
    assert told == study.config.instructed
    rows = Store(database_url(folder)).rows()
    assert [r["trial"] for r in rows] == list(range(index)) and index == 1 + 2 * study.config.scenes_per_set
    assert rows[1]["refused"] == 1


def test_two_simulations_with_one_seed_give_the_same_data_and_exclusions(tmp_path):
    """The simulated participant clicks only on what it saw ``delay_s`` ago, and waits for the server's answer
    to each click before it looks again, so the server stamps a pick at the look that made it: two runs with
    one seed give the same rows (all but the three *_utc columns, the wall-clock time the run was made) and
    the same exclusions under the default rules. (Issue 75: it clicked at its first look, before its own
    reaction time, and the server stamped that pick at 0.15 or 0.30 s by a race, so the early-pick rule
    excluded different participants in two runs.)"""
    model = ParticipantModel()
    tables = []
    for run in ("a", "b"):
        synthetic_study(tmp_path / run)  # the default screening rules, the early pick's included
        store = Store(database_url(tmp_path / run))
        assert simulate(read_study(tmp_path / run), tmp_path / run, store, 2, model=model, seed=11) == ["DONE42"] * 2
        assert main(["study", "analyze", "--study", str(tmp_path / run), "--out", str(tmp_path / f"{run}-analysed")]) == 0
        lines = (tmp_path / f"{run}-analysed" / "responses.csv").read_text().splitlines()
        header = lines[0].split(",")
        keep = [i for i, name in enumerate(header) if not name.endswith("_utc")]
        rows = [[row[i] for i in keep] for row in csv.reader(lines)]
        summary = json.loads((tmp_path / f"{run}-analysed" / "summary.json").read_text())
        tables.append((rows, summary["excluded"], summary["analysed_participants"]))
        picks = [float(r["first_pick_s"]) for r in csv.DictReader(lines) if r["first_pick_s"]]
        assert picks and min(picks) >= model.delay_s - 1e-9, min(picks)  # it saw before it clicked
    assert len(tables[0][0]) == 1 + 2 * 5 and tables[0] == tables[1]


def test_simulate_takes_a_study_whose_every_click_comes_after_the_end(tmp_path):
    """A participant that is never sure during the motion (``commit`` above 1) clicks its best guess after each
    motion's end; on a study whose every duration rounds up to the millisecond that was the click the server
    refused, and `scdp study simulate` stopped (issue 75). Every pick is now stored, at the end of its motion."""
    study = synthetic_study(tmp_path / "s", duration_s=1.2347, points={"dp": 37, "scdp": 41},
                            screening={"min_first_pick_s": 0.0})
    store = Store(database_url(tmp_path / "s"))
    assert simulate(study, tmp_path / "s", store, 2, model=ParticipantModel(commit=1.01), seed=3) == ["DONE42"] * 2
    picks = store.engine.connect().exec_driver_sql("SELECT server_t, client_t FROM picks").fetchall()
    assert len(picks) >= 2 * 5 and all(s == 1.0 and 0.999 <= c <= 1.0 for s, c in picks), picks
