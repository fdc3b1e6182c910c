"""End-to-end tests of the ``tacreasoner`` command on tiny datasets (2 clips, 1 worker)."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner import __version__, cli
from tacreasoner.cli import app

runner = CliRunner()
TINY = ["--objects", "2", "--repeats", "1", "--sensors", "mini", "--workers", "1"]


def invoke(*args: str):
    return runner.invoke(app, [str(a) for a in args])


def assert_one_line_error(result, *needles: str) -> None:
    """Argument errors must be exactly one ``error: …`` line on stderr, exit code 2, no traceback."""
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    for needle in needles:
        assert needle in lines[0]
    assert "Traceback" not in result.output


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sim") / "ds"
    result = invoke("simulate", "--out", out, *TINY)
    assert result.exit_code == 0, result.output
    return out


def snapshot(out: Path) -> dict[str, int]:
    return {p.relative_to(out).as_posix(): p.stat().st_mtime_ns for p in sorted((out / "clips").rglob("*"))}


# ------------------------------------------------------------------------------------------ simulate


def test_simulate_writes_manifest_and_videos(dataset: Path) -> None:
    lines = (dataset / "manifest.jsonl").read_text().splitlines()
    assert len(lines) == 2
    for line in lines:
        record = json.loads(line)
        assert (dataset / record["video"]).stat().st_size > 1000
        assert record["video"].endswith(".mp4")
    assert len(list((dataset / "clips" / "mini").glob("*.mp4"))) == 2
    assert json.loads((dataset / "dataset.json").read_text())["n_clips"] == 2


def test_simulate_resumes_without_rewriting(dataset: Path) -> None:
    before, manifest = snapshot(dataset), (dataset / "manifest.jsonl").read_bytes()
    result = invoke("simulate", "--out", dataset, *TINY)
    assert result.exit_code == 0, result.output
    assert "resumed from disk" in result.stdout
    assert snapshot(dataset) == before
    assert (dataset / "manifest.jsonl").read_bytes() == manifest


def test_simulate_summary_names_manifest(tmp_path: Path) -> None:
    out = tmp_path / "ds"
    result = invoke("simulate", "--out", out, "--objects", "1", "--repeats", "2", "--workers", "1")
    assert result.exit_code == 0, result.output
    assert "2 clips" in result.stdout and "frames/s" in result.stdout
    assert str(out / "manifest.jsonl") in result.stdout


def test_different_settings_in_same_dir_is_refused(dataset: Path) -> None:
    before = snapshot(dataset)
    result = invoke("simulate", "--out", dataset, "--objects", "3", "--repeats", "1", "--workers", "1")
    assert_one_line_error(result, "different settings")
    assert snapshot(dataset) == before


@pytest.mark.parametrize(("args", "needle"), [
    (["--objects", "-3"], "--objects"),
    (["--objects", "0"], "--objects"),
    (["--repeats", "0"], "--repeats"),
    (["--workers", "0"], "--workers"),
    (["--sensors", "mini,gelsight9"], "gelsight9"),
    (["--sensors", "mini@0"], "mini@0"),
])
def test_invalid_values_give_one_line(tmp_path: Path, args: list[str], needle: str) -> None:
    result = invoke("simulate", "--out", tmp_path / "ds", *args)
    assert_one_line_error(result, needle)
    assert not (tmp_path / "ds").exists()


def test_unwritable_out_dir_gives_one_line(tmp_path: Path) -> None:
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a directory")
    result = invoke("simulate", "--out", blocker / "sub", "--objects", "1", "--repeats", "1")
    assert_one_line_error(result, str(blocker / "sub"))


# ------------------------------------------------------------------------------------------ sim-preview


def assert_pngs(paths: list[Path]) -> None:
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.stat().st_size > 20_000


def test_sim_preview_of_catalogue_object(tmp_path: Path) -> None:
    out = tmp_path / "prev" / "apple.png"
    result = invoke("sim-preview", "--out", out, "--object", "apple_real")
    assert result.exit_code == 0, result.output
    assert_pngs([out, out.with_name("apple_signals.png")])
    assert str(out) in result.stdout


def test_sim_preview_of_dataset_clip(dataset: Path, tmp_path: Path) -> None:
    out = tmp_path / "clip.png"
    result = invoke("sim-preview", "--out", out, "--dataset", dataset, "--clip", "mini/apple_fake_0")
    assert result.exit_code == 0, result.output
    assert_pngs([out, tmp_path / "clip_signals.png"])


@pytest.mark.parametrize(("args", "needle"), [
    (["--object", "kiwi_real"], "kiwi_real"),
    (["--action", "twist"], "twist"),
    (["--sensor", "gelsight9"], "gelsight9"),
    (["--clip", "mini/apple_real_0"], "--dataset"),
])
def test_sim_preview_bad_arguments(tmp_path: Path, args: list[str], needle: str) -> None:
    assert_one_line_error(invoke("sim-preview", "--out", tmp_path / "p.png", *args), needle)


def test_sim_preview_missing_dataset_or_clip(dataset: Path, tmp_path: Path) -> None:
    assert_one_line_error(invoke("sim-preview", "--out", tmp_path / "p.png", "--dataset", tmp_path / "none"),
                          "manifest")
    assert_one_line_error(invoke("sim-preview", "--out", tmp_path / "p.png", "--dataset", dataset,
                                 "--clip", "mini/nothing_0"), "mini/nothing_0")


# ------------------------------------------------------------------------------------------ quickstart


def test_quickstart_runs_named_stages(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def no_llm(*args: object) -> None:
        raise AssertionError("--no-train started the LLM pre-training")

    monkeypatch.setattr(cli, "_start_llm_pretraining", no_llm)
    out = tmp_path / "qs"
    result = invoke("quickstart", "--out", out, "--objects", "2", "--repeats", "1", "--workers", "1", "--no-train")
    assert result.exit_code == 0, result.output
    for n, stage in enumerate(("simulate", "preview", "benchmark", "baselines", "touchcot"), 1):
        assert f"[{n}/5] {stage}" in result.stdout
    assert len((out / "sim" / "manifest.jsonl").read_text().splitlines()) == 2
    assert_pngs([out / "preview" / f"mini_apple_{kind}_0{suffix}.png"
                 for kind in ("real", "fake") for suffix in ("", "_signals")])
    assert "data stages finished" in result.stdout and not (out / "train").exists()


FAKE_PRETRAINING = """
import json, sys, time
from pathlib import Path
out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
(out / "pretrain.json").write_text(json.dumps({"settings": {"steps": 20}}))
for step in (10, 20):
    with (out / "train_log.jsonl").open("a") as f:
        f.write(json.dumps({"step": step, "loss": 1.5}) + "\\n")
    time.sleep(0.1)
if len(sys.argv) > 2:
    print("Traceback (most recent call last):\\nRuntimeError: fake failure", file=sys.stderr)
    sys.exit(1)
(out / "model.safetensors").write_bytes(b"weights")
(out / "config.json").write_text("{}")
(out / "pretrain.json").write_text(json.dumps({"settings": {"steps": 20}, "parameters": 123456, "steps_done": 20,
                                               "final_loss": 1.5, "train_seconds": 3.2}))
"""


def _stage(stages: list, name: str):
    return next(stage for stage in stages if stage.name == name)


def test_quickstart_pretrains_the_encoder_while_the_background_llm_finishes(tmp_path: Path) -> None:
    """The encoder's stage comes before the wait for the LLM, and both before training."""
    names = [stage.name for stage in cli._training_stages(tmp_path / "qs", 0, 1, 1, None)]
    assert names.index("encoder") < names.index("pretrain-llm") < names.index("train")


def fake_pretraining(monkeypatch: pytest.MonkeyPatch, *extra: str) -> None:
    monkeypatch.setattr(cli, "_llm_pretraining_command",
                        lambda llm_dir, seed: [sys.executable, "-c", FAKE_PRETRAINING, str(llm_dir), *extra])


def test_quickstart_llm_stage_waits_for_the_background_pretraining_then_skips_it(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fake_pretraining(monkeypatch)
    out = tmp_path / "qs"
    job = cli._start_llm_pretraining(out, 0)
    assert job is not None and job.log == out / "llm.log"
    stage = _stage(cli._training_stages(out, 0, 1, 1, job), "pretrain-llm")
    assert cli._llm_steps(out / "llm") in (None, (0, 20), (10, 20), (20, 20))
    assert stage.run() == ["0.1 M parameters, 20 steps, final loss 1.5, 3 s",
                           f"trained in the background at 1 thread alongside the data stages; log: {out / 'llm.log'}"]
    assert cli._llm_steps(out / "llm") == (20, 20)
    assert cli._start_llm_pretraining(out, 0) is None  # a re-run starts nothing …
    assert _stage(cli._training_stages(out, 0, 1, 1, None), "pretrain-llm").run() == [
        f"already trained: {out / 'llm'}"]  # … and says so


def test_quickstart_llm_failure_names_the_log_and_quotes_it(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    fake_pretraining(monkeypatch, "--fail")
    out = tmp_path / "qs"
    job = cli._start_llm_pretraining(out, 0)
    with pytest.raises(OSError) as info:  # cli_errors makes it one error line
        _stage(cli._training_stages(out, 0, 1, 1, job), "pretrain-llm").run()
    line = cli._one_line(info.value)
    assert "pretrain-llm failed (exit code 1)" in line and str(out / "llm.log") in line
    assert "RuntimeError: fake failure" in line


def test_quickstart_llm_pretraining_command_resumes_at_one_thread(tmp_path: Path,
                                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    command = cli._llm_pretraining_command(tmp_path / "llm", 7)
    assert command[:3] == [sys.executable, "-m", "tacreasoner"]
    calls: list[dict] = []

    def pretrain_llm(out: Path, **kwargs: object) -> Path:
        calls.append(kwargs)
        out.mkdir(parents=True)
        (out / "pretrain.json").write_text(json.dumps({"parameters": 1, "vocab_size": 1, "steps_done": 1,
                                                       "tokens_seen": 1, "train_seconds": 1, "final_loss": 1}))
        return out

    monkeypatch.setattr("tacreasoner.train.pretrain_llm.pretrain_llm", pretrain_llm)
    monkeypatch.setattr("tacreasoner.train.pretrain_llm.knowledge_check", None)  # --no-eval: never called
    result = invoke(*command[3:])
    assert result.exit_code == 0, result.output
    assert len(calls) == 1 and calls[0]["threads"] == 1 and calls[0]["resume"] and calls[0]["seed"] == 7


@pytest.mark.parametrize("failure", [ValueError("simulation broke"), KeyboardInterrupt()])
def test_quickstart_starts_the_llm_first_and_stops_it_when_a_stage_fails(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failure: BaseException) -> None:
    monkeypatch.setattr(cli, "_llm_pretraining_command",
                        lambda llm_dir, seed: [sys.executable, "-c", "import time; time.sleep(60)"])
    started = []
    start = cli._start_llm_pretraining
    monkeypatch.setattr(cli, "_start_llm_pretraining", lambda out, seed: started.append(start(out, seed)) or started[0])

    def simulation(*args: object) -> None:
        assert len(started) == 1 and started[0].process.poll() is None  # running before the first stage
        raise failure

    monkeypatch.setattr(cli, "run_simulation", simulation)
    result = invoke("quickstart", "--out", tmp_path / "qs", "--objects", "2", "--repeats", "1")
    assert result.exit_code == (2 if isinstance(failure, ValueError) else 130), result.output
    assert "simulation broke" in result.stderr or isinstance(failure, KeyboardInterrupt)
    assert started[0].process.returncode == -signal.SIGTERM  # stopped (and reaped) by the quickstart


def test_quickstart_rejects_bad_counts(tmp_path: Path) -> None:
    assert_one_line_error(invoke("quickstart", "--out", tmp_path / "qs", "--repeats", "-1"), "--repeats")
    assert_one_line_error(invoke("quickstart", "--out", tmp_path / "qs", "--seeds", "0"), "--seeds")


# ------------------------------------------------------------------------------------------ app


def test_version() -> None:
    result = invoke("--version")
    assert result.exit_code == 0
    assert result.stdout.strip() == f"tacreasoner {__version__}"


def test_installed_entry_point_prints_one_line_errors(tmp_path: Path) -> None:
    """The real console script (not just CliRunner): one stderr line, exit 2, nothing on stdout."""
    exe = Path(sys.executable).with_name("tacreasoner")
    if not exe.exists():
        pytest.skip("tacreasoner console script not installed in this environment")
    proc = subprocess.run([str(exe), "simulate", "--out", str(tmp_path / "ds"), "--objects", "-3"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip() == "error: number of objects (--objects) must be at least 1, got -3"
    assert proc.stdout == ""
