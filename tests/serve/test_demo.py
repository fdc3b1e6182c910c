"""The web demo: its plots and question handling, and the page itself driven in headless Chromium."""

from __future__ import annotations

import itertools
import logging
import os
import shutil
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tacreasoner.serve import TactileEngine
from tacreasoner.serve.demo import (
    EXAMPLE_CHOICES,
    EXAMPLES,
    FRAMES_SHOWN,
    INTERNAL_ERROR,
    MAX_CLIPS,
    UPLOAD_MAX_AGE_S,
    UPLOAD_SWEEP_S,
    DemoCallbacks,
    build_demo,
    clip_views,
    example_clips,
    heat_figure,
    question_for,
)
from tacreasoner.serve.stepwise import StepwiseAnswerer
from tests.serve.served import ONE, free_port, press_clip

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
def examples(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return example_clips(tmp_path_factory.mktemp("examples"))


def _shown(views: list[Any]) -> list[list[str]]:
    """The captions of each visible clip gallery, from a callback's gallery updates."""
    return [[caption for _, caption in g["value"]] for g in views[:MAX_CLIPS] if g["visible"]]


def test_a_new_upload_or_example_replaces_the_clips_before(clip_files: list[Path], examples: dict[str, Path]) -> None:
    calls = DemoCallbacks(None, examples, warn=pytest.fail)  # type: ignore[arg-type]
    box, held, menu, *views = calls.upload([str(clip_files[0])], [])
    assert box == held == [str(clip_files[0])] and menu is None
    assert _shown(views)[0][0] == "press_0.mp4: frame 0"
    # gradio's multi-file box adds the next upload to the files before it: the new upload alone is kept
    box, held, menu, *views = calls.upload([str(clip_files[0]), str(clip_files[1]), str(clip_files[2])], held)
    assert box == held == [str(p) for p in clip_files[1:]]
    assert [captions[0] for captions in _shown(views)] == ["press_1.mp4: frame 0", "press_2.mp4: frame 0"]
    box, held, *views = calls.pick("real vs fake apple (slide)")  # an example replaces the uploads
    assert box is None and held == [] and len(_shown(views)) == 2
    assert [g["label"] for g in views[:2]] == list(EXAMPLE_CHOICES["real vs fake apple (slide)"])
    box, held, *views = calls.pick("sponge (rotate)")  # and the next example the one before
    assert [g["label"] for g in views[:MAX_CLIPS] if g["visible"]] == ["sponge (rotate)"]
    held, *views = calls.files_changed([str(clip_files[2])])  # a file removed from the box: the ones left
    assert held == [str(clip_files[2])] and len(_shown(views)) == 1


def test_each_clip_has_its_own_gallery_showing_all_its_frames(clip_files: list[Path],
                                                              examples: dict[str, Path]) -> None:
    calls = DemoCallbacks(None, examples, warn=pytest.fail)  # type: ignore[arg-type]
    *_, heat, curve = views = calls.upload([str(p) for p in clip_files], [])[3:]
    shown = _shown(views)
    assert len(shown) == 3 and all(len(c) == FRAMES_SHOWN for c in shown)
    assert [c[0].split(":")[0] for c in shown] == [p.name for p in clip_files]
    assert heat is not None and curve is not None
    page = build_demo(None, examples)  # type: ignore[arg-type]
    galleries = {b.elem_id: b for b in page.blocks.values() if b.elem_id and b.elem_id.startswith("frames-")}
    assert sorted(galleries) == [f"frames-{k}" for k in range(MAX_CLIPS)]
    assert all(g.columns == FRAMES_SHOWN and g.height is None for g in galleries.values()), \
        "one row per clip, in a gallery tall enough for it (no scroll)"


def test_heat_map_titles_stay_inside_the_figure_and_apart() -> None:
    names = ["a_very_long_uploaded_file_name_from_a_phone_camera.mp4", "another_long_name_for_clip_two_2024.mp4",
             "c.mp4"]
    fig = heat_figure([press_clip(k) for k in range(3)], names)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [ax.title.get_window_extent(renderer) for ax in fig.axes if ax.get_title()]
    boxes.append(fig.get_suptitle() and fig._suptitle.get_window_extent(renderer))
    assert len(boxes) == 4
    assert all(b.x0 >= 0 and b.x1 <= fig.bbox.x1 and b.y0 >= 0 and b.y1 <= fig.bbox.y1 for b in boxes), \
        "no title is cut by the figure's edge"
    assert all(a.x1 < b.x0 for a, b in itertools.pairwise(boxes[:3])), "titles side by side do not overlap"
    assert any(t.get_text().endswith("…") for ax in fig.axes for t in [ax.title]), "long names are shortened"
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_user_errors_are_a_message_and_one_log_line_not_a_traceback(tmp_path: Path, clip_files: list[Path],
                                                                    write_clip: Callable[..., Path],
                                                                    caplog: pytest.LogCaptureFixture,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"not a video" * 20)
    still = write_clip("still.mp4", press_clip(0)[5:6])
    warned: list[str] = []
    calls = DemoCallbacks(None, {}, max_frames=8, warn=warned.append)  # type: ignore[arg-type]
    with caplog.at_level(logging.WARNING, logger="tacreasoner.demo"):
        views = calls.upload([str(junk)], [])[3:]
        assert views[-2:] == (None, None) and _shown(views) == []
        replies = {"missing": list(calls.ask(None, None, "Is it soft?", False)),
                   "bad": list(calls.ask([str(junk)], None, "Is it soft?", False)),
                   "still": list(calls.ask([str(still)], None, "Is it soft?", False)),
                   "long": list(calls.ask([str(clip_files[0])], None, "Is it soft?", False))}
    assert warned[0].startswith("junk.mp4: not a readable video (") and warned[0].count("not a readable") == 1
    assert replies["missing"] == [("", "", "**no clip: upload a clip or pick a simulated example first**")]
    assert replies["bad"] == [("", "", f"**{warned[0]}**")]
    assert "still.mp4: the clip has 1 frame" in replies["still"][0][2]
    assert "press_0.mp4: longer than 8 frames" in replies["long"][0][2]
    assert len(warned) == 5 and [r.getMessage() for r in caplog.records] == [f"demo: {w}" for w in warned]
    assert "Traceback" not in capsys.readouterr().err


def test_the_demos_own_errors_keep_their_traceback_in_the_log_and_say_internal_error(
        clip_files: list[Path], caplog: pytest.LogCaptureFixture) -> None:
    class Broken:
        def stream(self, *args: Any, **kwargs: Any) -> Any:
            raise ValueError("shape mismatch deep inside")  # a ValueError, but not the user's mistake

    warned: list[str] = []
    calls = DemoCallbacks(Broken(), {}, warn=warned.append)  # type: ignore[arg-type]
    with caplog.at_level(logging.WARNING, logger="tacreasoner.demo"):
        replies = list(calls.ask([str(clip_files[0])], None, "Is it soft?", False))
    assert replies == [("", "", f"**{INTERNAL_ERROR}**")] and warned == [INTERNAL_ERROR]
    [record] = caplog.records
    assert record.levelno == logging.ERROR and record.exc_info and "shape mismatch" in str(record.exc_info[1])


def test_the_page_sweeps_old_uploads(examples: dict[str, Path]) -> None:
    page = build_demo(None, examples)  # type: ignore[arg-type]
    assert page.delete_cache == (UPLOAD_SWEEP_S, UPLOAD_MAX_AGE_S) and UPLOAD_MAX_AGE_S <= 86400


def test_a_stepwise_demo_shows_each_clips_reading_for_a_comparison(served_model: Path,
                                                                   clip_files: list[Path]) -> None:
    engine = TactileEngine.load(served_model, device="cpu")
    calls = DemoCallbacks(engine, {}, warn=pytest.fail, stepwise=StepwiseAnswerer("stepwise", "physiclear"))
    *_, (reasoning, answer, status) = calls.ask([str(p) for p in clip_files[:2]], None,
                                                "Which of the two feels harder?", False)
    assert reasoning.startswith("Video 1: ") and "Video 2: " in reasoning, reasoning
    assert answer in ("the first object", "the second object") and status.startswith("stepwise: 2 passes")
    *_, (_, _, one_status) = calls.ask([str(clip_files[0])], None, "Is this object soft or hard?", False)
    assert "passes" not in one_status  # one clip: one pass, as before
    auto = DemoCallbacks(engine, {}, warn=pytest.fail, stepwise=StepwiseAnswerer("auto", "physiclear"))
    *_, (_, _, asked_status) = auto.ask([str(clip_files[0])], None, "Is this lemon a fake one?", False)
    assert asked_status.startswith("auto: asked as “A tactile sensor pressed on something that looks like a lemon: "
                                   "<tactile>\nIs it a real lemon or a fake one?”")


@pytest.fixture(scope="module")
def demo_url(served_model: Path, examples: dict[str, Path]) -> Iterator[str]:
    engine = TactileEngine.load(served_model, device="cpu")
    page = build_demo(engine, examples, max_new_tokens=40)
    port = free_port()
    page.launch(server_name="127.0.0.1", server_port=port, prevent_thread_lock=True, quiet=True)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        page.close()


def test_the_page_in_headless_chromium_uploads_asks_and_shows_the_answer(demo_url: str, clip_files: list[Path],
                                                                          tmp_path: Path,
                                                                          capfd: pytest.CaptureFixture[str]) -> None:
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
            expect(page.locator("#frames-0 img").first).to_be_visible(timeout=60_000)
            expect(page.locator("#curve img")).to_be_visible(timeout=60_000)
            page.locator("#question textarea").fill(ONE)
            page.locator("#ask").click()
            expect(page.locator("#answer textarea")).to_have_value("soft", timeout=60_000)
            expect(page.locator("#reasoning textarea")).to_have_value("The imprint is deep and wide, so it is soft.")
            time.sleep(0.5)
            page.screenshot(path=str(shots / "demo.png"), full_page=True)
            # a second upload replaces the first; each of its two clips gets a gallery
            page.locator("#clips input[type=file]").first.set_input_files([str(p) for p in clip_files[1:]])
            expect(page.locator("#frames-1 img").first).to_be_visible(timeout=60_000)
            expect(page.locator("#clips tr.file")).to_have_count(2)
            expect(page.locator("#clips")).not_to_contain_text("press_0")
            junk = tmp_path / "junk.mp4"
            junk.write_bytes(b"not a video" * 20)
            page.locator("#clips input[type=file]").first.set_input_files(str(junk))
            expect(page.get_by_text("junk.mp4: not a readable video").first).to_be_visible(timeout=60_000)
            expect(page.locator("#frames-0")).to_be_hidden()
        finally:
            browser.close()
    image = (shots / "demo.png").read_bytes()
    assert image[:8] == b"\x89PNG\r\n\x1a\n" and len(image) > 20_000
    assert np.frombuffer(image, np.uint8).size == len(image)
    assert "Traceback" not in capfd.readouterr().err, "a user's mistake is a message, not a traceback"
