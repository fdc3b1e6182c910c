"""`tacreasoner ask` (streamed and --json) and `tacreasoner serve` as a user runs them."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx
import openai
import pytest
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.serve.media import video_data_url
from tests.serve.served import ONE, free_port


def test_ask_streams_the_reasoning_then_the_answer(served_model: Path, clip_files: list[Path]) -> None:
    result = CliRunner().invoke(app, ["ask", ONE, "--video", str(clip_files[0]), "--model", str(served_model)])
    assert result.exit_code == 0, result.output
    lines = result.output[result.output.index("think:"):].splitlines()
    assert lines[0] == "think: The imprint is deep and wide, so it is soft."
    assert lines[1] == "answer: soft"
    assert "tokens in" in lines[2] and lines[2].endswith("stop")


def test_ask_json_is_one_object_with_think_answer_and_timings(served_model: Path, clip_files: list[Path]) -> None:
    result = CliRunner().invoke(app, ["ask", ONE, "--video", str(clip_files[0]), "--model", str(served_model),
                                      "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.stdout)
    assert (out["think"], out["answer"], out["finish_reason"]) == \
        ("The imprint is deep and wide, so it is soft.", "soft", "stop")
    assert out["usage"]["completion_tokens"] > 5 and out["timings"]["total_s"] > 0


def test_ask_errors_are_one_line(served_model: Path, clip_files: list[Path], tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["ask", "No placeholder here", "--video", str(clip_files[0]), "--model",
                                      str(served_model)])
    assert result.exit_code == 2 and "0 <tactile> placeholder(s) but 1 video" in result.output
    result = CliRunner().invoke(app, ["ask", ONE, "--video", str(clip_files[0]), "--model", str(tmp_path)])
    assert result.exit_code == 2 and "not a saved TacReasoner model" in result.output
    for option, value, said in (("--max-new-tokens", "0", "--max-new-tokens must be at least 1, got 0"),
                                 ("--top-p", "1.5", "--top-p must be in (0, 1], got 1.5"),
                                 ("--dtype", "half", "dtype must be one of float32, bfloat16, auto; got 'half'")):
        # the model folder is not one: the option is checked first, and named as this command names it
        result = CliRunner().invoke(app, ["ask", ONE, "--video", str(clip_files[0]), "--model", str(tmp_path),
                                          "--sample", option, value])
        assert result.exit_code == 2 and said in result.output and "max_tokens" not in result.output, result.output


def test_serve_answers_the_openai_client(served_model: Path, clip_files: list[Path]) -> None:
    port = free_port()
    env = {**os.environ, "TACREASONER_API_KEY": "k", "OMP_NUM_THREADS": "1"}
    server = subprocess.Popen([sys.executable, "-m", "tacreasoner", "serve", "--model", str(served_model),
                               "--port", str(port), "--allow-dir", str(clip_files[0].parent)],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                if httpx.get(f"http://127.0.0.1:{port}/health").status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert server.poll() is None and time.monotonic() < deadline, server.stdout.read() if server.stdout \
                else "server exited"
            time.sleep(0.2)
        client = openai.OpenAI(base_url=f"http://127.0.0.1:{port}/v1", api_key="k", max_retries=0)
        content = [{"type": "video_url", "video_url": {"url": video_data_url(clip_files[0])}},
                   {"type": "text", "text": ONE}]
        reply = client.chat.completions.create(model="tacreasoner", max_tokens=40,
                                               messages=[{"role": "user", "content": content}])
        assert reply.choices[0].message.content == "soft"
    finally:
        server.terminate()
        server.wait(timeout=30)


@pytest.mark.parametrize("listening", [True, False])
def test_serve_finds_a_taken_port_before_loading_the_model(tmp_path: Path, listening: bool) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        if listening:
            taken.listen()
        port = taken.getsockname()[1]
        started = time.monotonic()
        result = CliRunner().invoke(app, ["serve", "--model", str(tmp_path), "--port", str(port)])  # not a model
    assert result.exit_code == 2 and time.monotonic() - started < 30
    assert result.output.strip().splitlines() == \
        [f"error: cannot listen on 127.0.0.1:{port}: Address already in use (is another server running there?)"]


def test_serve_threads_sets_torchs_threads_and_is_checked(served_model: Path, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    import torch

    from tacreasoner.serve import http

    help_text = CliRunner().invoke(app, ["serve", "--help"], env={"COLUMNS": "200"}).output
    assert "--threads" in help_text and "torch.set_num_threads" in help_text
    result = CliRunner().invoke(app, ["serve", "--model", str(tmp_path), "--threads", "0"])
    assert result.exit_code == 2 and result.output.strip() == "error: --threads must be at least 1, got 0"
    result = CliRunner().invoke(app, ["serve", "--model", str(tmp_path), "--dtype", "half"])
    assert result.exit_code == 2 and "dtype must be one of float32, bfloat16, auto; got 'half'" in result.output
    seen: dict[str, Any] = {}

    def served(app: Any, host: str, port: int, sock: socket.socket | None = None, **kwargs: Any) -> None:
        seen.update(threads=torch.get_num_threads(), bound=sock.getsockname() if sock else None)

    monkeypatch.setattr(http, "serve_forever", served)
    before = torch.get_num_threads()
    port = free_port()
    try:
        result = CliRunner().invoke(app, ["serve", "--model", str(served_model), "--port", str(port), "--threads",
                                          "1"])
    finally:
        torch.set_num_threads(before)
    assert result.exit_code == 0, result.output
    assert seen == {"threads": 1, "bound": ("127.0.0.1", port)} and "torch threads: 1" in result.output


def test_the_serve_extra_brings_the_openai_client_the_docs_use() -> None:
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    pyproject = tomllib.loads((Path(__file__).resolve().parents[2] / "pyproject.toml").read_text())
    extras = pyproject["project"]["optional-dependencies"]
    assert "openai>=1.40" in extras["serve"] and "openai>=1.40" in extras["api"]


def test_ask_stepwise_reads_each_video_and_shows_the_readings(served_model: Path, clip_files: list[Path],
                                                               tmp_path: Path) -> None:
    question = "Which of these feels harder: <tactile> or <tactile>?"
    base = ["ask", question, "--video", str(clip_files[0]), "--video", str(clip_files[1]), "--model",
            str(served_model), "--answers", "stepwise"]
    result = CliRunner().invoke(app, [*base, "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.stdout)
    assert out["answers"] == "stepwise" and out["think"].startswith("Video 1: ") and "Video 2: " in out["think"]
    assert out["answer"] in ("the first object", "the second object")  # the rule's answer, whatever was read
    assert out["timings"]["steps"] == 2  # one pass per video
    streamed = CliRunner().invoke(app, base)
    assert streamed.exit_code == 0 and "think: Video 1: " in streamed.output and "stepwise: 2 passes" in streamed.output
    # a question it does not read is answered in one pass, and said so
    other = CliRunner().invoke(app, ["ask", ONE, "--video", str(clip_files[0]), "--model", str(served_model),
                                     "--answers", "stepwise"])
    assert other.exit_code == 0 and "answered in one pass" in other.output
    voted = CliRunner().invoke(app, [*base[:-1], "stepwise-vote", "--json"])
    assert voted.exit_code == 0 and json.loads(voted.stdout)["timings"]["steps"] == 8  # 2 videos x 4 wordings
    # stepwise-vote reads a one-clip question in a person's words: always a word of the asked property
    firm = CliRunner().invoke(app, ["ask", "How firm does this feel? <tactile>", "--video", str(clip_files[0]),
                                    "--model", str(served_model), "--answers", "stepwise-vote", "--json"])
    assert firm.exit_code == 0, firm.output
    read = json.loads(firm.stdout)
    assert read["answer"] in ("soft", "moderately hard", "hard") and read["timings"]["steps"] == 4
    assert read["think"].startswith("Video 1: ")
    # a question touch cannot answer gets a reply that says so, not a level word, and runs no pass
    for mode in ("stepwise-vote", "auto"):
        colour = CliRunner().invoke(app, ["ask", "What colour is this? <tactile>", "--video", str(clip_files[0]),
                                          "--model", str(served_model), "--answers", mode, "--json"])
        told = json.loads(colour.stdout)
        assert told["answer"] == "I can't tell its colour from touch." and told["timings"]["steps"] == 0
        assert "does not sense colour" in told["think"]
    # auto asks a person's comparison or real-or-fake question again in the benchmark's words, in one pass
    two = ["--video", str(clip_files[0]), "--video", str(clip_files[1])]
    for mode, steps in (("auto", 1), ("stepwise-vote", 8)):
        compared = CliRunner().invoke(app, ["ask", "<tactile>\n<tactile>\nOut of the pair, which one is harder?",
                                            *two, "--model", str(served_model), "--answers", mode, "--json"])
        said = json.loads(compared.stdout)
        assert said["timings"]["steps"] == steps
        assert said.get("asked_as") == ("A sensor touched two objects in turn: <tactile> then <tactile>\nWhich of "
                                        "the two objects feels harder?" if mode == "auto" else None)
    fruit = CliRunner().invoke(app, ["ask", "Is this orange a fake? <tactile>", "--video", str(clip_files[0]),
                                     "--model", str(served_model), "--answers", "auto"])
    assert fruit.exit_code == 0 and "asked in the benchmark's words, one pass: " in fruit.output
    assert "Is it a real orange or a fake one?" in fruit.output
    three = CliRunner().invoke(app, ["ask", "Of these, which is the softest? <tactile> <tactile> <tactile>", *two,
                                     "--video", str(clip_files[0]), "--model", str(served_model), "--answers", "auto",
                                     "--json"])
    voted = json.loads(three.stdout)
    assert voted["timings"]["steps"] == 3 and "softest" in voted["asked_as"]  # SOI: three wordings, the majority
    # without --vocabulary the clip is read in the level words recorded in the model folder
    from tacreasoner.tasks.vocab import get_vocabulary

    dyntac = tmp_path / "dyntac_model"
    dyntac.mkdir()
    for f in served_model.iterdir():
        (dyntac / f.name).symlink_to(f.resolve())
    config = json.loads((served_model / "processor_config.json").read_text())
    (dyntac / "processor_config.json").unlink()
    (dyntac / "processor_config.json").write_text(json.dumps({**config, "vocabulary": "vtv150k"}))
    own = CliRunner().invoke(app, ["ask", "How firm does this feel? <tactile>", "--video", str(clip_files[0]),
                                   "--model", str(dyntac), "--answers", "auto", "--json"])
    assert own.exit_code == 0, own.output
    assert json.loads(own.stdout)["answer"] in get_vocabulary("vtv150k")["hardness"].levels
    # without --answers, the mode its recipe recorded in the folder (else direct)
    from tacreasoner.model.processing import record_answers

    plain = CliRunner().invoke(app, ["ask", "How firm does this feel? <tactile>", "--video", str(clip_files[0]),
                                     "--model", str(dyntac), "--json"])
    assert "steps" not in json.loads(plain.stdout)["timings"]  # direct: one pass
    (dyntac / "processor_config.json").unlink()
    (dyntac / "processor_config.json").write_text(json.dumps({**config, "vocabulary": "vtv150k"}))
    record_answers(dyntac, "auto")
    recorded = CliRunner().invoke(app, ["ask", "How firm does this feel? <tactile>", "--video", str(clip_files[0]),
                                        "--model", str(dyntac), "--json"])
    said = json.loads(recorded.stdout)
    assert said["answers"] == "auto" and said["timings"]["steps"] == 4
    bad = CliRunner().invoke(app, [*base, "--vocabulary", "octopi"])
    assert bad.exit_code == 2 and "unknown vocabulary 'octopi'" in bad.output


@pytest.mark.parametrize(("options", "said"), [
    (["--decode-timeout", "0"], "error: --decode-timeout must be above 0, got 0"),
    (["--max-request-mb", "0"], "error: --max-request-mb must be above 0, got 0"),
    (["--max-request-mb", "-1"], "error: --max-request-mb must be above 0, got -1"),
    (["--answers", "twice"], "error: answers must be one of direct, stepwise, stepwise-vote, auto; got 'twice'"),
])
def test_serve_refuses_at_start_what_would_fail_every_request(tmp_path: Path, options: list[str], said: str) -> None:
    result = CliRunner().invoke(app, ["serve", "--model", str(tmp_path), "--port", str(free_port()), *options])
    assert result.exit_code == 2 and result.output.strip().splitlines() == [said]  # before any model is loaded


def test_demo_finds_a_taken_port_before_loading_the_model(tmp_path: Path) -> None:
    pytest.importorskip("gradio")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = CliRunner().invoke(app, ["demo", "--model", str(tmp_path), "--port", str(port),
                                          "--examples", str(tmp_path / "examples")])  # not a model
    assert result.exit_code == 2, result.output
    assert result.output.strip().splitlines() == \
        [f"error: cannot listen on 127.0.0.1:{port}: Address already in use (is another server running there?)"]
    assert not (tmp_path / "examples").exists(), "nothing is made before the port is known to be free"
