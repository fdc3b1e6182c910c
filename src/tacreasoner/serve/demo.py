"""``tacreasoner demo``: a web page to show what the sensor felt next to what the model said (gradio).

Upload one to three clips (or pick simulated ones), see sampled frames, where the gel changed (the mean
frame-difference heat map) and how the contact built up and let go (contact energy with the detected phases), ask a
question and watch the reasoning stream in. The plots come from :mod:`tacreasoner.data.cues`, the same signals the
TouchCoT teacher reads.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tacreasoner.data.cues import detect_phases, frame_signals
from tacreasoner.data.video import read_video, write_video
from tacreasoner.serve.engine import Prompt, Reply, RequestError, Sampling, TactileEngine
from tacreasoner.serve.stream import Delta
from tacreasoner.tasks.schema import PLACEHOLDER

__all__ = ["EXAMPLES", "build_demo", "clip_views", "example_clips", "question_for"]

EXAMPLES = {"real apple (slide)": ("apple_real", "slide"), "fake apple (slide)": ("apple_fake", "slide"),
            "sponge (rotate)": ("sponge", "rotate"), "metal (slide)": ("metal", "slide")}
"""Simulated GelSight Mini clips the page offers without an upload: name → (material, action)."""
MAX_CLIPS = 3
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


def clip_views(clips: Sequence[np.ndarray], names: Sequence[str], fps: Sequence[float], n_frames: int = 6,
               ) -> tuple[list[tuple[np.ndarray, str]], np.ndarray, np.ndarray]:
    """Sampled frames (captioned), the frame-difference heat maps side by side, and the contact-energy curves
    with their detected phases."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gallery = []
    for frames, name in zip(clips, names, strict=True):
        for t in np.linspace(0, len(frames) - 1, n_frames).round().astype(int):
            gallery.append((frames[t], f"{name}: frame {t}"))
    heat_fig, axes = plt.subplots(1, len(clips), figsize=(3.2 * len(clips), 2.8), squeeze=False)
    curve_fig, curve_axes = plt.subplots(len(clips), 1, figsize=(6.4, 1.9 * len(clips)), squeeze=False)
    for k, (frames, name, rate) in enumerate(zip(clips, names, fps, strict=True)):
        grey = frames.astype(np.float32).mean(axis=-1)
        heat = np.abs(grey - grey[0]).mean(axis=0)
        image = axes[0, k].imshow(heat, cmap="inferno")
        axes[0, k].set_title(f"{name}\nmean |frame − first frame|", fontsize=8)
        axes[0, k].axis("off")
        heat_fig.colorbar(image, ax=axes[0, k], fraction=0.046)
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
        ax.set_title(name, fontsize=8)
        ax.set_ylabel("contact energy", fontsize=8)
        if ax.get_legend_handles_labels()[1]:
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    curve_axes[-1, 0].set_xlabel("time (s)")
    curve_fig.tight_layout()
    return gallery, _figure_png(heat_fig), _figure_png(curve_fig)


def _chosen(uploaded: Sequence[Any] | None, picked: Sequence[str] | None,
            examples: dict[str, Path]) -> list[tuple[str, Path]]:
    files = [(Path(getattr(f, "name", f)).name, Path(getattr(f, "name", f))) for f in uploaded or []]
    files += [(name, examples[name]) for name in picked or [] if name in examples]
    if len(files) > MAX_CLIPS:
        raise RequestError(f"{len(files)} clips chosen; the demo takes 1 to {MAX_CLIPS}")
    return files


def build_demo(engine: TactileEngine, examples: dict[str, Path], *, max_new_tokens: int = 256) -> Any:
    """The gradio Blocks app (``.launch()`` it)."""
    os.environ.setdefault("GRADIO_ANALYTICS_ENABLED", "False")
    import gradio as gr

    def show(uploaded: Any, picked: Any) -> tuple[Any, Any, Any]:
        try:
            chosen = _chosen(uploaded, picked, examples)
            if not chosen:
                return [], None, None
            decoded = [read_video(path) for _, path in chosen]
        except (RequestError, ValueError, FileNotFoundError) as exc:
            raise gr.Error(str(exc)) from None
        return clip_views([f for f, _ in decoded], [n for n, _ in chosen], [r for _, r in decoded])

    def ask(uploaded: Any, picked: Any, question: str, sample: bool) -> Iterator[tuple[str, str, str]]:
        try:
            chosen = _chosen(uploaded, picked, examples)
            if not chosen:
                raise RequestError("upload a clip or pick a simulated example first")
            prompt = Prompt.ask(question_for(question.strip(), len(chosen)), [str(p) for _, p in chosen])
            sampling = Sampling(max_new_tokens=max_new_tokens, temperature=0.7 if sample else 0.0,
                                top_p=0.9 if sample else 1.0)
            parts = {"reasoning": "", "content": ""}
            for piece in engine.stream(prompt, sampling):
                if isinstance(piece, Delta):
                    parts[piece.channel] += piece.text
                    yield parts["reasoning"], parts["content"], "answering…"
                elif isinstance(piece, Reply):
                    t = piece.timings
                    yield piece.reasoning, piece.content or "(no answer)", \
                        f"{piece.completion_tokens} tokens in {t['total_s']:.2f} s ({piece.finish_reason})"
        except (RequestError, ValueError, FileNotFoundError) as exc:
            raise gr.Error(str(exc)) from None

    with gr.Blocks(title="TacReasoner") as page:
        gr.Markdown("# TacReasoner\nTactile clips in, reasoning and an answer out. Upload 1 to 3 GelSight-style "
                    "videos or pick simulated ones; write `<tactile>` where each clip belongs in the question, "
                    "or leave it out and the clips go first.")
        with gr.Row():
            uploaded = gr.File(label="Tactile clips (1 to 3)", file_count="multiple",
                               file_types=[".mp4", ".mov", ".avi", ".mkv", ".webm"], elem_id="clips")
            picked = gr.Dropdown(list(examples), label="…or simulated examples (GelSight Mini)", multiselect=True,
                                 max_choices=MAX_CLIPS, elem_id="examples")
        gallery = gr.Gallery(label="Sampled frames", columns=6, height=220, elem_id="frames")
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
        for source in (uploaded, picked):
            source.change(show, [uploaded, picked], [gallery, heat, curve])
        button.click(ask, [uploaded, picked, question, sample], [reasoning, answer, status])
        question.submit(ask, [uploaded, picked, question, sample], [reasoning, answer, status])
    return page
