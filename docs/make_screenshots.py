"""Regenerate the README's viewer screenshot (``docs/viewer.png``) in headless Chromium.

Run from the repository root after ``armpath reach 20 -200 120 --out /tmp/reach`` (or give
another result): ``python docs/make_screenshots.py /tmp/reach/reach.json``. Needs Debian's
chromium and the ``playwright`` package (in the ``test`` extra).
"""

from __future__ import annotations

import shutil
import sys
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

from armpath.results import load_result
from armpath.viewer.app import HEADLESS_CHROMIUM_ARGS, ArmViewer, free_port

OUT = Path(__file__).resolve().parent / "viewer.png"


def main(result_path: str, command: int = 40) -> int:
    result = load_result(result_path)
    port = free_port()
    viewer = ArmViewer(result.arm, result.scene, port=port, result=result)
    viewer.show_command(min(command, result.sequence.n_commands))
    chromium = shutil.which("chromium")
    if chromium is None:
        sys.exit("needs Debian's chromium")
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(
                executable_path=chromium,
                args=list(HEADLESS_CHROMIUM_ARGS),
            )
            page = browser.new_page(viewport={"width": 1280, "height": 760})
            page.goto(f"http://127.0.0.1:{port}")
            page.wait_for_selector("text=Fingertip", timeout=60000)
            time.sleep(3)
            # Dismiss the software-rendering notice of headless Chromium.
            for button in page.locator("button.mantine-Notification-closeButton").all():
                button.click()
            time.sleep(1)
            page.screenshot(path=str(OUT))
            browser.close()
    finally:
        viewer.stop()
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1] if len(sys.argv) > 1 else "/tmp/reach/reach.json"))
