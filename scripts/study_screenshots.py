"""Screenshots of every page of ``scdp study serve`` at desktop and phone widths, into docs/study/.

    python scripts/study_screenshots.py --run results/cpu --out docs/study

Makes a small study per task from the cpu checkpoints (in a temporary folder), serves it, and
photographs in headless Chromium: consent, instructions, a Block Reach and a Navigation trial
(before Start, mid-motion with a goal picked, and at the end), and the completion page. Motions
play over 3 s here (6 s in a default study) so the run is short.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from playwright.sync_api import sync_playwright

from scdp.cli import main as scdp_main
from scdp.study.app import create_app
from scdp.study.make import read_study
from scdp.study.participant import ServerThread, launch_browser, wait_screen
from scdp.study.store import Store, database_url

SIZES = {"desktop": (1280, 860), "phone": (390, 844)}


def shoot(folder: Path, task: str, out: Path, first: bool) -> None:
    study = read_study(folder)
    with ServerThread(create_app(study, folder, Store(database_url(folder)))) as url, sync_playwright() as pw:
        browser = launch_browser(pw)
        for size, (w, h) in SIZES.items():
            page = browser.new_page(viewport={"width": w, "height": h}, device_scale_factor=1)
            pid = f"shot-{size}"
            page.goto(f"{url}/?pid={pid}")
            wait_screen(page, ("consent",))
            if first:
                page.screenshot(path=out / f"{size}_consent.png", full_page=True)
            page.check("#consent-box")
            page.click("#consent-go")
            wait_screen(page, ("instructions",))
            if first:
                page.screenshot(path=out / f"{size}_instructions.png", full_page=True)
            page.click("#instructions-go")
            wait_screen(page, ("trial",))
            page.screenshot(path=out / f"{size}_{task}_practice_before_start.png", full_page=True)
            page.click("#start")
            page.wait_for_function("window.study.t > 0.55")
            page.click("#goal-0")
            page.screenshot(path=out / f"{size}_{task}_practice_mid_motion.png", full_page=True)
            page.wait_for_function("window.study.done")
            page.click("#confirm")
            wait_screen(page, ("trial",), after_index=0)
            page.click("#start")
            page.wait_for_function("window.study.done")
            page.click("#goal-1")
            page.screenshot(path=out / f"{size}_{task}_trial_end.png", full_page=True)
            if first:  # the rest as a participant would, then the completion page
                while page.evaluate("window.study.screen") == "trial":
                    index = page.evaluate("window.study.index")
                    if not page.evaluate("window.study.started"):
                        page.click("#start")
                    page.wait_for_function("window.study.playing")
                    page.click("#goal-0")
                    page.wait_for_function("window.study.done")
                    page.click("#confirm")
                    page.wait_for_function(f"window.study.screen === 'done' || window.study.index > {index}")
                wait_screen(page, ("done",))
                page.screenshot(path=out / f"{size}_done.png", full_page=True)
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
                          "--out", str(folder)]) != 0:
                raise SystemExit(f"scdp study make failed for {task}")
            shoot(folder, task, out, first=i == 0)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"wrote {len(list(out.glob('*.png')))} screenshots to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
