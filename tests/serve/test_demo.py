"""The web demo: its plots and question handling, and the page itself driven in headless Chromium."""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from served import ONE, free_port, press_clip

from tacreasoner.serve import TactileEngine
from tacreasoner.serve.demo import EXAMPLES, build_demo, clip_views, example_clips, question_for

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
BROWSER_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def test_views_show_frames_heat_map_and_phased_contact_curve() -> None:
    clips = [press_clip(0, frames=30), press_clip(1, frames=20)]
    gallery, heat, curve = clip_views(clips, ["a", "b"], [10.0, 25.0], n_frames=4)
    assert len(gallery) == 8 and gallery[0][1] == "a: frame 0" and gallery[0][0].shape == (48, 48, 3)
    assert heat.ndim == 3 and heat.shape[1] > heat.shape[0], "one heat map per clip, side by side"
    assert curve.ndim == 3 and curve.shape[0] > 200, "one curve per clip, stacked"
    assert heat.std() > 0 and curve.std() > 0


def test_questions_get_one_placeholder_per_clip_unless_they_place_them() -> None:
    assert question_for("Is it soft?", 1) == "<tactile>\nIs it soft?"
    assert question_for("Which is rougher?", 2) == "Video 1: <tactile>\nVideo 2: <tactile>\nWhich is rougher?"
    assert question_for(ONE, 1) == ONE


def test_examples_are_simulated_once_and_reused(tmp_path: Path) -> None:
    first = example_clips(tmp_path)
    assert list(first) == list(EXAMPLES) and all(p.stat().st_size > 1000 for p in first.values())
    stamps = {p: p.stat().st_mtime_ns for p in first.values()}
    assert example_clips(tmp_path) == first and {p: p.stat().st_mtime_ns for p in first.values()} == stamps


@pytest.fixture(scope="module")
def demo_url(served_model: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    engine = TactileEngine.load(served_model, device="cpu")
    page = build_demo(engine, example_clips(tmp_path_factory.mktemp("examples")), max_new_tokens=40)
    port = free_port()
    page.launch(server_name="127.0.0.1", server_port=port, prevent_thread_lock=True, quiet=True)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        page.close()


def test_the_page_in_headless_chromium_uploads_asks_and_shows_the_answer(demo_url: str, clip_files: list[Path],
                                                                          tmp_path: Path) -> None:
    if not Path(CHROMIUM).is_file():
        if os.environ.get("TACREASONER_REQUIRE_BROWSER"):
            pytest.fail(f"{CHROMIUM} is missing but TACREASONER_REQUIRE_BROWSER is set (.ci/run installs it)")
        pytest.skip("Debian's chromium is not installed (apt-get install chromium; .ci/run does)")
    from playwright.sync_api import expect, sync_playwright

    shots = Path(os.environ.get("TACREASONER_SCREENSHOTS", tmp_path))
    shots.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=BROWSER_FLAGS)
        try:
            page = browser.new_page(viewport={"width": 1280, "height": 1400})
            page.goto(demo_url, wait_until="networkidle")
            page.locator("#clips input[type=file]").set_input_files(str(clip_files[0]))
            expect(page.locator("#frames img").first).to_be_visible(timeout=60_000)
            expect(page.locator("#curve img")).to_be_visible(timeout=60_000)
            page.locator("#question textarea").fill(ONE)
            page.locator("#ask").click()
            expect(page.locator("#answer textarea")).to_have_value("soft", timeout=60_000)
            expect(page.locator("#reasoning textarea")).to_have_value("The imprint is deep and wide, so it is soft.")
            time.sleep(0.5)
            page.screenshot(path=str(shots / "demo.png"), full_page=True)
        finally:
            browser.close()
    image = (shots / "demo.png").read_bytes()
    assert image[:8] == b"\x89PNG\r\n\x1a\n" and len(image) > 20_000
    assert np.frombuffer(image, np.uint8).size == len(image)
