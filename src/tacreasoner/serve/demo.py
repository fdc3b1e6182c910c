"""``tacreasoner demo``: a web page to show what the sensor felt next to what the model said (gradio).

Upload one to three clips (or pick a simulated one, or a simulated pair), see sampled frames, where the gel changed
(the mean frame-difference heat map) and how the contact built up and let go (contact energy with the detected
phases), ask a question and watch the reasoning stream in. The plots come from :mod:`tacreasoner.data.cues`, the same
signals the TouchCoT teacher reads. Each upload or pick replaces the clips shown before; a user's mistake (no clip,
an unreadable or too short or too long clip, too many clips) is a warning on the page and one log line, never a
traceback; anything else is the demo's fault: logged with its traceback, and the page says an internal error
happened. Uploads are kept by gradio for a day at most (:data:`UPLOAD_MAX_AGE_S`), swept every hour. With
``answers="stepwise"`` (or ``stepwise-vote``) a question comparing clips is answered as ``ask --answers`` does: each
clip read in a pass of its own, the readings and the rule's step shown as the reasoning.
"""

from __future__ import annotations

import io
import logging
import os
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tacreasoner.data.cues import detect_phases, frame_signals
from tacreasoner.evaluate.predict import REPLY_TOKENS
from tacreasoner.serve.engine import Prompt, Reply, RequestError, Sampling, TactileEngine, check_clip_length
from tacreasoner.serve.media import MediaLimits
from tacreasoner.serve.stepwise import StepwiseAnswerer
from tacreasoner.serve.stream import Delta
from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.video_io import VideoError, probe_video, read_video, write_video

__all__ = ["EXAMPLES", "EXAMPLE_CHOICES", "DemoCallbacks", "build_demo", "chosen_clips", "clip_views",
           "example_clips", "heat_figure", "latest_upload", "question_for", "read_clips"]

log = logging.getLogger("tacreasoner.demo")

EXAMPLES = {"real apple (slide)": ("apple_real", "slide"), "fake apple (slide)": ("apple_fake", "slide"),
            "sponge (rotate)": ("sponge", "rotate"), "metal (slide)": ("metal", "slide")}
"""Simulated GelSight Mini clips the page offers without an upload: name → (material, action)."""
EXAMPLE_CHOICES = {**{name: (name,) for name in EXAMPLES},
                   "real vs fake apple (slide)": ("real apple (slide)", "fake apple (slide)"),
                   "sponge vs metal": ("sponge (rotate)", "metal (slide)")}
"""What the examples menu offers: one clip, or a pair to compare. One choice at a time, since a new choice replaces
the clips shown before (a menu that added each pick to the last ones piled clips up unseen)."""
MAX_CLIPS = 3
FRAMES_SHOWN = 6
"""Sampled frames shown per clip: one row of its own gallery."""
TITLE_CHARS = 28
"""Longest clip name in a plot title; longer names (uploads' file names) are shortened so titles never overlap."""
USER_ERRORS = (RequestError, VideoError, FileNotFoundError)
"""A user's mistakes: shown on the page, logged in one line, no traceback. Any other error is the demo's own."""
INTERNAL_ERROR = "internal error: the demo's log has the traceback"
UPLOAD_SWEEP_S = 3600
UPLOAD_MAX_AGE_S = 86400
"""gradio's cache (uploads included) is swept every hour of files older than a day: a demo left running for weeks
does not fill its disk with every clip anyone uploaded."""
PHASE_COLOURS = {"press": "#4e79a7", "hold": "#59a14f", "slide": "#f28e2b", "rotate": "#f28e2b",
                 "dynamic": "#f28e2b", "release": "#e15759"}


def example_clips(folder: str | os.PathLike[str]) -> dict[str, Path]:
    """The simulated examples as .mp4 files in ``folder``, made once (a few seconds) and reused."""
    from tacreasoner.sim.generate import simulate_clip
    from tacreasoner.sim.materials import get_material

    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    out = {}
    for k, (name, (material, action)) in enumerate(EXAMPLES.items()):
        path = root / f"{material}_{action}.mp4"
        if not path.is_file():
            clip = simulate_clip(get_material(material), "mini", action, seed=(7, k, 0, 0))
            write_video(path, clip.frames, fps=clip.sensor.fps)
        out[name] = path
    return out


def question_for(question: str, n_clips: int) -> str:
    """The question as the model takes it: with no ``<tactile>`` written, one per clip goes before it."""
    if PLACEHOLDER in question or n_clips == 0:
        return question
    if n_clips == 1:
        return f"{PLACEHOLDER}\n{question}"
    return "".join(f"Video {k}: {PLACEHOLDER}\n" for k in range(1, n_clips + 1)) + question


def _figure_png(fig: Any) -> np.ndarray:
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    buffer.seek(0)
    return plt.imread(buffer, format="png")[..., :3]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _short(name: str, chars: int = TITLE_CHARS) -> str:
    return name if len(name) <= chars else name[:chars - 1] + "…"


def heat_figure(clips: Sequence[np.ndarray], names: Sequence[str]) -> Any:
    """The frame-difference heat maps side by side, one (shortened) name above each; the constrained layout keeps
    titles and colour bars inside the figure and apart."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, len(clips), figsize=(3.2 * len(clips), 3.0), squeeze=False, layout="constrained")
    fig.suptitle("mean |frame − first frame|", fontsize=9)
    for k, (frames, name) in enumerate(zip(clips, names, strict=True)):
        grey = frames.astype(np.float32).mean(axis=-1)
        heat = np.abs(grey - grey[0]).mean(axis=0)
        image = axes[0, k].imshow(heat, cmap="inferno")
        axes[0, k].set_title(_short(name), fontsize=8)
        axes[0, k].axis("off")
        fig.colorbar(image, ax=axes[0, k], fraction=0.046)
    return fig


def _curve_figure(clips: Sequence[np.ndarray], names: Sequence[str], fps: Sequence[float]) -> Any:
    plt = _pyplot()
    fig, curve_axes = plt.subplots(len(clips), 1, figsize=(6.4, 1.9 * len(clips)), squeeze=False,
                                   layout="constrained")
    for k, (frames, name, rate) in enumerate(zip(clips, names, fps, strict=True)):
        signals = frame_signals(frames)
        phases = detect_phases(signals)
        seconds = np.arange(len(frames)) / rate
        ax = curve_axes[k, 0]
        ax.plot(seconds, signals.intensity, color="black", lw=1.2)
        for phase, colour in PHASE_COLOURS.items():
            inside = phases == phase
            if inside.any():
                ax.fill_between(seconds, 0, signals.intensity.max() * 1.05, where=inside, color=colour, alpha=0.25,
                                label=phase, step="mid")
        ax.set_title(_short(name, 2 * TITLE_CHARS), fontsize=8)
        ax.set_ylabel("contact energy", fontsize=8)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    curve_axes[-1, 0].set_xlabel("time (s)")
    return fig


def clip_views(clips: Sequence[np.ndarray], names: Sequence[str], fps: Sequence[float],
               n_frames: int = FRAMES_SHOWN) -> tuple[list[tuple[np.ndarray, str]], np.ndarray, np.ndarray]:
    """Sampled frames (captioned; ``n_frames`` per clip, clip after clip), the frame-difference heat maps side by
    side, and the contact-energy curves with their detected phases."""
    gallery = []
    for frames, name in zip(clips, names, strict=True):
        for t in np.linspace(0, len(frames) - 1, n_frames).round().astype(int):
            gallery.append((frames[t], f"{name}: frame {t}"))
    return gallery, _figure_png(heat_figure(clips, names)), _figure_png(_curve_figure(clips, names, fps))


def _paths(files: Sequence[Any] | None) -> list[Path]:
    """Paths of what a file box holds (gradio gives paths, or objects with a ``name``)."""
    return [Path(getattr(f, "name", f)) for f in files or []]


def latest_upload(files: Sequence[Any] | None, before: Sequence[str]) -> list[Path]:
    """The files of the latest upload alone: gradio's multi-file box adds each upload to the files before it, but a
    new upload should replace the clips shown."""
    paths = _paths(files)
    new = [p for p in paths if str(p) not in set(before)]
    return new or paths


def chosen_clips(uploads: Sequence[Path], choice: str | None, examples: dict[str, Path]) -> list[tuple[str, Path]]:
    """(name, path) of the clips to show and ask about: the uploads, else the chosen example(s)."""
    files = [(p.name, p) for p in uploads] or \
        [(name, examples[name]) for name in EXAMPLE_CHOICES.get(choice or "", ()) if name in examples]
    if len(files) > MAX_CLIPS:
        raise RequestError(f"{len(files)} clips chosen; the demo takes 1 to {MAX_CLIPS}")
    return files


def read_clips(chosen: Sequence[tuple[str, Path]], max_frames: int = MediaLimits().max_frames,
               ) -> tuple[list[np.ndarray], list[float]]:
    """Each clip's frames and fps; too long (more than ``max_frames``, as the server's limit), too short or
    unreadable is a ``ValueError`` naming the clip, said once."""
    frames, fps = [], []
    for name, path in chosen:
        too_long = RequestError(f"{name}: longer than {max_frames} frames; the demo takes clips up to that length")
        if probe_video(path).n_frames > max_frames:  # before decoding it all
            raise too_long
        clip, rate = read_video(path)  # whole: a truncated file is refused, not shown in part
        if len(clip) > max_frames:
            raise too_long
        check_clip_length(len(clip), name)
        frames.append(clip)
        fps.append(rate)
    return frames, fps


class DemoCallbacks:
    """What the page's events call, kept apart from the page so that tests call them directly. Each returns the new
    values of its outputs; a user's mistake (:data:`USER_ERRORS`) goes to ``warn`` (``gr.Warning``: a message on the
    page) and one log line instead of a traceback, and leaves the views empty."""

    def __init__(self, engine: TactileEngine, examples: dict[str, Path], *, max_new_tokens: int = REPLY_TOKENS,
                 max_frames: int = MediaLimits().max_frames, warn: Callable[[str], Any] | None = None,
                 stepwise: StepwiseAnswerer | None = None) -> None:
        import gradio as gr

        self.gr = gr
        self.engine = engine
        self.stepwise = stepwise or StepwiseAnswerer()
        self.examples = examples
        self.max_new_tokens = max_new_tokens
        self.max_frames = max_frames
        self.warn = warn or gr.Warning

    def _fail(self, exc: BaseException) -> str:
        if not isinstance(exc, USER_ERRORS):  # the demo's fault: the traceback goes to the log
            log.error("demo: %s", INTERNAL_ERROR, exc_info=exc)
            self.warn(INTERNAL_ERROR)
            return INTERNAL_ERROR
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        log.warning("demo: %s", message)
        self.warn(message)
        return message

    def _views(self, chosen: Sequence[tuple[str, Path]]) -> tuple[Any, ...]:
        """One gallery per clip (its frames in one row, never hidden in a scroll), the heat maps, the curves."""
        hidden = self.gr.update(value=None, visible=False)
        if not chosen:
            return (*[hidden] * MAX_CLIPS, None, None)
        try:
            frames, fps = read_clips(chosen, self.max_frames)
            names = [name for name, _ in chosen]
            gallery, heat, curve = clip_views(frames, names, fps, FRAMES_SHOWN)
        except Exception as exc:
            self._fail(exc)
            return (*[hidden] * MAX_CLIPS, None, None)
        galleries = [self.gr.update(value=gallery[k * FRAMES_SHOWN:(k + 1) * FRAMES_SHOWN], label=names[k],
                                    visible=True) for k in range(len(chosen))]
        return (*galleries, *[hidden] * (MAX_CLIPS - len(chosen)), heat, curve)

    def upload(self, files: Sequence[Any] | None, before: Sequence[str] | None) -> tuple[Any, ...]:
        """A new upload: its files replace the clips before (uploaded or picked). Outputs: the file box, what it
        holds now (state), the examples menu (cleared), the views."""
        latest = latest_upload(files, before or [])
        try:
            chosen = chosen_clips(latest, None, self.examples)
        except Exception as exc:
            self._fail(exc)
            chosen = []
        return ([str(p) for p in latest], [str(p) for p in latest], None, *self._views(chosen))

    def files_changed(self, files: Sequence[Any] | None) -> tuple[Any, ...]:
        """A file removed from the box, or the box cleared: the clips left. Outputs: state, the views."""
        paths = _paths(files)
        try:
            chosen = chosen_clips(paths, None, self.examples)
        except Exception as exc:
            self._fail(exc)
            chosen = []
        return ([str(p) for p in paths], *self._views(chosen))

    def pick(self, choice: str | None) -> tuple[Any, ...]:
        """An example chosen from the menu: it replaces the clips before. Outputs: the file box (emptied), state,
        the views."""
        return (None, [], *self._views(chosen_clips([], choice, self.examples)))

    def ask(self, files: Sequence[Any] | None, choice: str | None, question: str, sample: bool,
            ) -> Iterator[tuple[str, str, str]]:
        """(reasoning, answer, status) as the reply streams in."""
        try:
            chosen = chosen_clips(_paths(files), choice, self.examples)
            if not chosen:
                raise RequestError("no clip: upload a clip or pick a simulated example first")
            if not question.strip():
                raise RequestError("no question: write one first")
            frames, _ = read_clips(chosen, self.max_frames)  # decoded once, checked: a message naming the clip
            prompt = Prompt.ask(question_for(question.strip(), len(chosen)), frames)
            sampling = Sampling(max_new_tokens=self.max_new_tokens, temperature=0.7 if sample else 0.0,
                                top_p=0.9 if sample else 1.0)
            view = self.stepwise.view(prompt, sampling)
            if view is not None:
                yield "", "", f"reading each clip ({self.stepwise.answers})…"
                reply = self.stepwise.answer(self.engine, view, frames)
                how = f"asked as “{reply.asked_as}”" if reply.asked_as else f"{int(reply.timings['steps'])} passes"
                yield reply.reasoning, reply.content or "(no answer)", f"{self.stepwise.answers}: {how}, " \
                    f"{reply.completion_tokens} tokens in {reply.timings['total_s']:.2f} s"
                return
            parts = {"reasoning": "", "content": ""}
            for piece in self.engine.stream(prompt, sampling):
                if isinstance(piece, Delta):
                    parts[piece.channel] += piece.text
                    yield parts["reasoning"], parts["content"], "answering…"
                elif isinstance(piece, Reply):
                    t = piece.timings
                    yield piece.reasoning, piece.content or "(no answer)", \
                        f"{piece.completion_tokens} tokens in {t['total_s']:.2f} s ({piece.finish_reason})"
        except Exception as exc:  # a user's mistake is said as such; the demo's own is logged with its traceback
            yield "", "", f"**{self._fail(exc)}**"


def build_demo(engine: TactileEngine, examples: dict[str, Path], *, max_new_tokens: int = REPLY_TOKENS,
               stepwise: StepwiseAnswerer | None = None) -> Any:
    """The gradio Blocks app (``.launch()`` it); ``stepwise``: how comparisons are answered (one pass by default)."""
    os.environ.setdefault("GRADIO_ANALYTICS_ENABLED", "False")
    import gradio as gr

    calls = DemoCallbacks(engine, examples, max_new_tokens=max_new_tokens, stepwise=stepwise)
    with gr.Blocks(title="TacReasoner", delete_cache=(UPLOAD_SWEEP_S, UPLOAD_MAX_AGE_S)) as page:
        gr.Markdown("# TacReasoner\nTactile clips in, reasoning and an answer out. Upload 1 to 3 GelSight-style "
                    "videos (each upload replaces the clips before) or pick a simulated example; write `<tactile>` "
                    "where each clip belongs in the question, or leave it out and the clips go first.")
        # the files the box held after the last upload; a hidden component, not gr.State (whose per-session
        # heartbeat keeps a connection open for as long as the page is)
        held = gr.JSON([], visible=False)
        with gr.Row():
            uploaded = gr.File(label="Tactile clips (1 to 3)", file_count="multiple",
                               file_types=[".mp4", ".mov", ".avi", ".mkv", ".webm"], elem_id="clips")
            choices = [name for name, parts in EXAMPLE_CHOICES.items() if all(p in examples for p in parts)]
            picked = gr.Dropdown(choices, value=None, label="…or a simulated example (GelSight Mini)",
                                 elem_id="examples")
        # one gallery per clip, one row each: its default height holds the row (one gallery of all the clips'
        # frames, 220 px high, hid the second clip's row in its scroll)
        galleries = [gr.Gallery(label=f"Clip {k + 1}: sampled frames", columns=FRAMES_SHOWN, visible=False,
                                elem_id=f"frames-{k}") for k in range(MAX_CLIPS)]
        with gr.Row():
            heat = gr.Image(label="Where the gel changed", elem_id="heat")
            curve = gr.Image(label="Contact energy and phases", elem_id="curve")
        with gr.Row():
            question = gr.Textbox(label="Question", value="Is this object soft or hard?", scale=4,
                                  elem_id="question")
            sample = gr.Checkbox(label="sample", value=False, scale=1)
            button = gr.Button("Ask", variant="primary", scale=1, elem_id="ask")
        reasoning = gr.Textbox(label="Reasoning", lines=4, elem_id="reasoning")
        answer = gr.Textbox(label="Answer", elem_id="answer")
        status = gr.Markdown(elem_id="status")
        views = [*galleries, heat, curve]
        # user actions only (upload, delete, clear, input): the values these callbacks set fire no new event
        uploaded.upload(calls.upload, [uploaded, held], [uploaded, held, picked, *views])
        uploaded.delete(calls.files_changed, [uploaded], [held, *views])
        uploaded.clear(calls.files_changed, [uploaded], [held, *views])
        picked.input(calls.pick, [picked], [uploaded, held, *views])
        button.click(calls.ask, [uploaded, picked, question, sample], [reasoning, answer, status])
        question.submit(calls.ask, [uploaded, picked, question, sample], [reasoning, answer, status])
    return page
