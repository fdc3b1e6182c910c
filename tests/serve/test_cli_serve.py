"""`tacreasoner ask` (streamed and --json) and `tacreasoner serve` as a user runs them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import httpx
import openai
from served import ONE, free_port
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.serve.media import video_data_url


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
