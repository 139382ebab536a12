"""Screenshots of every page of ``scdp study serve`` at desktop and phone widths, into docs/study/.

    python scripts/study_screenshots.py --run results/cpu --out docs/study

Makes a small study per task from the cpu checkpoints (in a temporary folder), serves it, and
photographs in headless Chromium: the declined page, consent, the instructions with their
comprehension check, a Block Reach and a Navigation practice (before Start, mid-motion with a goal
picked, at the end with the confidence asked), the practice's feedback, a trial's end, an
instructed-response check, the end-of-study ratings, the completion page with its debrief and its
Return button, and a lost session (the same ID in another browser). The median motion lasts 3 s here
(6 s in a default study) so the run is short.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

from scdp.cli import main as scdp_main
from scdp.study import questions
from scdp.study.app import create_app
from scdp.study.make import read_study
from scdp.study.participant import ServerThread, launch_browser, wait_screen
from scdp.study.store import Store, database_url

SIZES = {"desktop": (1280, 860), "phone": (390, 844)}


def answer(page, goal: int, confidence: int = 4) -> None:
    """Pick ``goal`` once the motion plays, then say how sure once it has ended."""
    if not page.evaluate("window.study.started"):
        page.click("#start")
    page.wait_for_function("window.study.playing")
    page.click(f"#goal-{goal}")
    page.wait_for_function("window.study.done")
    page.check(f"#confidence-{confidence}")


def shoot(folder: Path, task: str, out: Path, first: bool) -> None:
    study = read_study(folder)
    with ServerThread(create_app(study, folder, Store(database_url(folder)))) as url, sync_playwright() as pw:
        browser = launch_browser(pw)
        for size, (w, h) in SIZES.items():
            page = browser.new_page(viewport={"width": w, "height": h}, device_scale_factor=1)
            def snap(name, page=page, size=size):
                page.screenshot(path=out / f"{size}_{name}.png", full_page=True)

            if first:  # who does not agree leaves with the declined code
                page.goto(f"{url}/?pid=shot-declines-{size}")
                wait_screen(page, ("consent",))
                page.click("#consent-decline")
                wait_screen(page, ("declined",))
                snap("declined")
            page.goto(f"{url}/?pid=shot-{size}&STUDY_ID=demo&SESSION_ID=s-{size}")
            wait_screen(page, ("consent",))
            if first:
                snap("consent")
            page.check("#consent-box")
            page.click("#consent-go")
            wait_screen(page, ("instructions",))
            for i, right in enumerate(questions.ANSWERS):
                page.check(f"#q{i}-{right}")
            if first:
                snap("instructions")
            page.click("#instructions-go")
            wait_screen(page, ("trial",))
            snap(f"{task}_practice_before_start")
            page.click("#start")
            # past half of a 3 s median motion; a practice motion shorter than that is photographed at its end
            page.wait_for_function("window.study.t > 1.6 || window.study.done")
            page.click("#goal-0")
            snap(f"{task}_practice_mid_motion")
            page.wait_for_function("window.study.done")
            page.check("#confidence-4")
            snap(f"{task}_practice_end")
            page.click("#confirm")
            wait_screen(page, ("feedback",))
            snap("practice_feedback")
            page.click("#feedback-go")
            wait_screen(page, ("trial",), after_index=0)
            answer(page, 1)
            snap(f"{task}_trial_end")
            page.click("#confirm")
            page.wait_for_function("window.study.screen === 'ratings' || window.study.index > 1")
            instructed = False
            while page.evaluate("window.study.screen") == "trial":  # the rest as a participant would
                index = page.evaluate("window.study.index")
                answer(page, 0)
                if page.evaluate("window.study.note") and not instructed:
                    snap(f"{task}_instructed_check")
                    instructed = True
                page.click("#confirm")
                page.wait_for_function(f"window.study.screen === 'ratings' || window.study.index > {index}")
            wait_screen(page, ("ratings",))
            for i in range(len(page.evaluate("window.study.items"))):
                page.check(f"#legible-{i}-5")
                page.check(f"#predictable-{i}-4")
            snap(f"{task}_ratings")
            page.click("#ratings-go")
            wait_screen(page, ("done",))
            if first:
                snap("done")  # the code, the debrief and the Return button: the page stays until they leave
                lost = browser.new_page(viewport={"width": w, "height": h}, device_scale_factor=1)
                lost.goto(f"{url}/?pid=shot-{size}")  # the same ID in another browser: no session there
                wait_screen(lost, ("lost",))
                lost.screenshot(path=out / f"{size}_lost_session.png", full_page=True)
                lost.close()
            page.close()
        browser.close()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--run", default="results/cpu")
    p.add_argument("--out", default="docs/study")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="scdp-shots-"))
    try:
        for i, task in enumerate(("block_reach", "navigation")):
            folder = work / task
            if scdp_main(["study", "make", "--task", task, "--checkpoints", str(Path(args.run) / task / "checkpoints"),
                          "--scenes", "3", "--attention", "1", "--duration-s", "3", "--completion-code", "EXAMPLE1",
                          "--completion-url", "https://example.org/done?cc={code}",
                          "--out", str(folder)]) != 0:
                raise SystemExit(f"scdp study make failed for {task}")
            shoot(folder, task, out, first=i == 0)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"wrote {len(list(out.glob('*.png')))} screenshots to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
