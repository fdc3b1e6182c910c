"""A screenshot of `tacreasoner demo` answering about a simulated clip (the picture in the README and docs).

    python examples/demo_screenshot.py --model runs/quickstart/model --out docs/images/demo.png

Needs the serve extra, Playwright (the dev extra) and Debian's chromium (/usr/bin/chromium); nothing downloads a
browser. The page is driven as a person would: upload the clip, type the question, press Ask, wait for the answer.
"""

from __future__ import annotations

import argparse
import socket
import tempfile
import time
from pathlib import Path

BROWSER_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", type=Path, default=Path("runs/quickstart/model"))
    parser.add_argument("--out", type=Path, default=Path("docs/images/demo.png"))
    parser.add_argument("--example", default="fake apple (slide)")
    parser.add_argument("--question", default="Is this fruit real or fake?")
    parser.add_argument("--chromium", default="/usr/bin/chromium")
    args = parser.parse_args()

    from playwright.sync_api import expect, sync_playwright

    from tacreasoner.serve import TactileEngine
    from tacreasoner.serve.demo import build_demo, example_clips

    clips = example_clips(Path(tempfile.gettempdir()) / "tacreasoner_demo_examples")
    page_app = build_demo(TactileEngine.load(args.model), clips)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    page_app.launch(server_name="127.0.0.1", server_port=port, prevent_thread_lock=True, quiet=True)
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=args.chromium, args=BROWSER_FLAGS)
            page = browser.new_page(viewport={"width": 1280, "height": 1300})
            page.goto(f"http://127.0.0.1:{port}", wait_until="networkidle")
            page.locator("#clips input[type=file]").set_input_files(str(clips[args.example]))
            expect(page.locator("#curve img")).to_be_visible(timeout=120_000)
            page.locator("#question textarea").fill(args.question)
            page.locator("#ask").click()
            expect(page.locator("#status")).to_contain_text("tokens in", timeout=300_000)
            time.sleep(0.5)
            args.out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.out), full_page=True)
            print("answer:", page.locator("#answer textarea").input_value())
            browser.close()
    finally:
        page_app.close()
    print("wrote", args.out)


if __name__ == "__main__":
    main()
