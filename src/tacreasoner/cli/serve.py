"""``tacreasoner ask``, ``serve`` and ``demo``: a trained model answering a person, a robot, or a browser.

The model defaults to the quickstart's published one, so the commands work right after ``tacreasoner quickstart``.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from tacreasoner.cli.app import Dtype, app, at_least_one, cli_errors, console, needs_train_extra
from tacreasoner.recipes.quickstart import QUICKSTART_DIR

DEFAULT_MODEL = QUICKSTART_DIR / "model"
ASK_OPTIONS = {"max_tokens": "--max-new-tokens", "temperature": "--temperature", "top_p": "--top-p"}
"""The server's request field behind each of `ask`'s options (Sampling names its errors by the field)."""
ModelDir = Annotated[Path, typer.Option("--model", help="Trained model directory (a training run's stage2/model).")]
Host = Annotated[str, typer.Option(help="Address to listen on (0.0.0.0 for every interface).")]
Port = Annotated[int, typer.Option(help="TCP port.")]
Answers = Annotated[str | None, typer.Option(
    "--answers", show_default=False, help="Default: the mode recorded in the model folder by its recipe (the "
                      "quickstart's auto, the PhysiCLeAR recipe's stepwise-vote), else direct. direct: one pass; "
                      "stepwise: a question comparing objects (which is softer, more/less/similar, "
                      "the roughest of three, which named object is which, which suits a scenario) is answered by "
                      "reading each video in a pass of its own and concluding by rule, the readings shown (other "
                      "questions, and sampled ones, in one pass); stepwise-vote: each video read in every "
                      "single-clip wording, the majority level (how evaluate-physiclear answers; recommended for a "
                      "PhysiCLeAR model); auto: a question in a wording the model was trained on in one pass, a "
                      "comparison or real-or-fake question in other words asked again in the benchmark's, any other "
                      "as stepwise-vote.")]
Vocabulary = Annotated[str | None, typer.Option(
    "--vocabulary", help="With --answers stepwise[-vote]/auto: the level words the model was trained on (physiclear: "
                         "soft / moderately hard / hard …; vtv150k: DynTAC-Sim's). Default: the one recorded in the "
                         "model folder, else physiclear.", show_default=False)]


def _above_zero(option: str, value: float) -> None:
    """A limit of 0 or less would fail every request; it is refused at start instead."""
    if not value > 0:
        raise ValueError(f"{option} must be above 0, got {value:g}")


def _load_engine(model: Path, name: str = "tacreasoner", dtype: str = "float32") -> Any:
    """The model, loaded without transformers' weight-loading progress bar (noise before a streamed answer)."""
    from transformers.utils import logging as hf_logging

    from tacreasoner.serve import TactileEngine

    hf_logging.disable_progress_bar()
    return TactileEngine.load(model, name=name, dtype=dtype)


def _needs_serve_extra(command: str, modules: tuple[str, ...] = ("fastapi", "uvicorn")) -> None:
    try:
        for module in modules:
            importlib.import_module(module)
    except ImportError:
        raise ValueError(f'{command} needs the serve extra: pip install -e ".[train,serve]"') from None


@app.command()
@cli_errors
def ask(
    question: Annotated[str, typer.Argument(help="Question with one <tactile> per video, e.g. 'Is <tactile> soft?'.")],
    video: Annotated[list[Path], typer.Option("--video", help="Tactile video file, one per <tactile> (repeatable).")],
    model: ModelDir = DEFAULT_MODEL,
    max_new_tokens: Annotated[int, typer.Option("--max-new-tokens", help="Longest reply.")] = 512,
    sample: Annotated[bool, typer.Option("--sample/--greedy", help="Sample instead of greedy decoding.")] = False,
    temperature: Annotated[float, typer.Option(help="Sampling temperature (with --sample).")] = 0.7,
    top_p: Annotated[float, typer.Option("--top-p", help="Nucleus sampling mass (with --sample).")] = 0.9,
    seed: Annotated[int | None, typer.Option(help="Seed of the sampling (with --sample).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object (think, answer, timings) "
                                                         "instead of streaming.")] = False,
    dtype: Dtype = "float32",
    answers: Answers = None,
    vocabulary: Vocabulary = None,
) -> None:
    """Ask a trained model about tactile videos; streams its reasoning as it is generated, then the answer."""
    needs_train_extra("ask")
    from tacreasoner.evaluate.predict import check_dtype
    from tacreasoner.serve import Delta, Prompt, Reply, RequestError, Sampling
    from tacreasoner.serve.stepwise import StepwiseAnswerer, model_answers, model_vocabulary

    check_dtype(dtype)
    answers = answers or model_answers(model)
    stepwise = StepwiseAnswerer(answers, vocabulary or model_vocabulary(model))
    for path in video:
        if not path.is_file():
            raise FileNotFoundError(f"--video {path}: no such file")
    try:  # checked before the model loads, and said in this command's words, not the server's
        sampling = Sampling(max_new_tokens=max_new_tokens, temperature=temperature if sample else 0.0,
                            top_p=top_p if sample else 1.0, seed=seed)
    except RequestError as exc:
        option = ASK_OPTIONS.get(exc.param or "", exc.param or "")
        raise ValueError(str(exc).replace(exc.param or "", option, 1)) from None
    engine = _load_engine(model, dtype=dtype)
    prompt = Prompt.ask(question, [str(p) for p in video])
    if answers != "direct":
        view = stepwise.view(prompt)  # whatever --sample says: the readings are greedy
        if view is not None:
            stepped = stepwise.answer(engine, view, [str(p) for p in video])
            if as_json:
                typer.echo(json.dumps({"model": str(model), "videos": [str(v) for v in video], "answers": answers,
                                       **stepped.to_dict()}))
                return
            for label, text in (("think:", stepped.reasoning), ("answer:", stepped.content)):
                console.print(f"[bold]{label}[/bold] ", end="")
                console.print(text, markup=False, highlight=False)
            if stepped.asked_as is not None:
                console.print(f"[dim]asked in the benchmark's words, one pass: {stepped.asked_as!r} "
                              f"({stepped.timings['total_s']:.2f} s)[/dim]", highlight=False)
            else:
                console.print(f"[dim]stepwise: {int(stepped.timings['steps'])} passes, {stepped.completion_tokens} "
                              f"tokens in {stepped.timings['total_s']:.2f} s[/dim]")
            return
        from tacreasoner.tasks.paraphrase import trained_wording_of

        why = "a wording the model was trained on" if answers == "auto" and trained_wording_of(question) else \
            "not a question it reads (see --answers)"
        console.print(f"[dim]{answers}: {why}; answered in one pass[/dim]")
    if as_json:
        reply = engine.complete(prompt, sampling)
        typer.echo(json.dumps({"model": str(model), "videos": [str(v) for v in video], **reply.to_dict()}))
        return
    channel = None
    reply = None
    for piece in engine.stream(prompt, sampling):
        if isinstance(piece, Delta):
            if channel is None and piece.channel == "content":  # no reasoning came first: say so
                console.print("[bold]think:[/bold] (none)")
                channel = "reasoning"
            if piece.channel != channel:
                label = "think:" if piece.channel == "reasoning" else "answer:"
                console.print(("\n" if channel else "") + f"[bold]{label}[/bold] ", end="")
                channel = piece.channel
            console.print(piece.text, end="", markup=False)
            sys.stdout.flush()
        elif isinstance(piece, Reply):
            reply = piece
    if channel is None:
        console.print("[bold]think:[/bold] (none)")
    if reply is not None and not reply.content:
        console.print(("\n" if channel else "") + "[bold]answer:[/bold] (none: the reply ended without one)", end="")
    console.print()
    if reply is not None:
        t = reply.timings
        console.print(f"[dim]{reply.completion_tokens} tokens in {t['total_s']:.2f} s "
                      f"({t['tokens_per_s']:.0f} tokens/s; first after {t.get('first_token_s', 0):.2f} s); "
                      f"{reply.finish_reason}[/dim]")


@app.command()
@cli_errors
def serve(
    model: ModelDir = DEFAULT_MODEL,
    host: Host = "127.0.0.1",
    port: Port = 8000,
    name: Annotated[str, typer.Option(help="The model id clients send.")] = "tacreasoner",
    api_key: Annotated[str | None, typer.Option("--api-key", envvar="TACREASONER_API_KEY",
                                                help="Require 'Authorization: Bearer KEY' (or set "
                                                     "TACREASONER_API_KEY).")] = None,
    max_batch: Annotated[int, typer.Option("--max-batch", help="Non-streamed requests answered together; "
                                                               "1 turns batching off.")] = 8,
    max_pending: Annotated[int, typer.Option("--max-pending", help="Requests that may wait; more are told "
                                                                   "the server is busy (503).")] = 64,
    decode_timeout: Annotated[float, typer.Option("--decode-timeout", help="Seconds one reply may take.")] = 120.0,
    max_request_mb: Annotated[float, typer.Option("--max-request-mb", help="Largest request body.")] = 64.0,
    max_videos: Annotated[int, typer.Option("--max-videos", help="Videos per request.")] = 4,
    allow_dir: Annotated[list[Path] | None, typer.Option(
        "--allow-dir", help="Directory whose files clients may name as file:// URLs (repeatable).")] = None,
    threads: Annotated[int | None, typer.Option(
        "--threads", help="CPU threads the model may use (torch.set_num_threads; at least 1). Default: torch's "
                          "choice (usually one per core).", show_default=False)] = None,
    dtype: Dtype = "float32",
    answers: Answers = None,
    vocabulary: Vocabulary = None,
) -> None:
    """Serve a trained model with the OpenAI chat completions API (videos as video_url parts)."""
    needs_train_extra("serve")
    _needs_serve_extra("serve")
    from tacreasoner.evaluate.predict import check_dtype
    from tacreasoner.serve.http import bind_socket, serve_forever
    from tacreasoner.serve.media import MediaLimits
    from tacreasoner.serve.openai_api import ServerSettings, create_app
    from tacreasoner.serve.stepwise import model_answers, model_vocabulary

    answers = answers or model_answers(model)
    for value, option in ((max_batch, "--max-batch"), (max_pending, "--max-pending"), (max_videos, "--max-videos"),
                          (threads, "--threads")):
        at_least_one(option, value)
    _above_zero("--decode-timeout", decode_timeout)
    _above_zero("--max-request-mb", max_request_mb)
    if int(max_request_mb * 2**20) < 1:
        raise ValueError(f"--max-request-mb {max_request_mb:g} is under one byte")
    check_dtype(dtype)
    dirs = tuple(d.resolve() for d in allow_dir or [])
    for d in dirs:
        if not d.is_dir():
            raise FileNotFoundError(f"--allow-dir {d}: no such directory")
    settings = ServerSettings(api_key=api_key, max_request_bytes=int(max_request_mb * 2**20),  # checked: before loading
                              decode_timeout_s=decode_timeout, max_pending=max_pending, max_batch=max_batch,
                              limits=MediaLimits(max_videos=max_videos, allowed_dirs=dirs),
                              answers=answers, vocabulary=vocabulary or model_vocabulary(model))
    sock = bind_socket(host, port)  # a taken port is found now, not after loading the model
    try:
        if threads is not None:
            import torch

            torch.set_num_threads(threads)
        engine = _load_engine(model, name, dtype)
        console.print(f"serving {model} as {name!r} on http://{host}:{port}/v1 "
                      f"({'API key required' if api_key else 'no API key'}; batching up to {max_batch}"
                      f"{f'; torch threads: {threads}' if threads else ''}; answers: {answers})")
        serve_forever(create_app(engine, settings), host=host, port=port, sock=sock)
    finally:
        sock.close()


@app.command()
@cli_errors
def demo(
    model: ModelDir = DEFAULT_MODEL,
    host: Host = "127.0.0.1",
    port: Port = 7860,
    examples: Annotated[Path, typer.Option(help="Where the simulated example clips are made (once).")] =
        Path("runs/demo_examples"),
    dtype: Dtype = "float32",
    answers: Answers = None,
    vocabulary: Vocabulary = None,
) -> None:
    """A web page: upload 1-3 tactile clips (or pick simulated ones), see what the sensor felt, ask, watch the
    reasoning stream."""
    needs_train_extra("demo")
    _needs_serve_extra("demo", ("gradio",))
    from tacreasoner.evaluate.predict import check_dtype
    from tacreasoner.serve.demo import build_demo, example_clips
    from tacreasoner.serve.http import bind_socket
    from tacreasoner.serve.stepwise import StepwiseAnswerer, model_answers, model_vocabulary

    check_dtype(dtype)
    answers = answers or model_answers(model)
    stepwise = StepwiseAnswerer(answers, vocabulary or model_vocabulary(model))
    bind_socket(host, port).close()  # a taken port is found now, not after loading the model
    engine = _load_engine(model, dtype=dtype)
    clips = example_clips(examples)
    console.print(f"demo of {model} on http://{host}:{port} (answers: {answers})")
    build_demo(engine, clips, stepwise=stepwise).launch(
        server_name=host, server_port=port, show_error=True)
