"""End-to-end tests of the ``tacreasoner`` command on tiny datasets (2 clips, 1 worker)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner import __version__
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


def test_quickstart_runs_named_stages(tmp_path: Path) -> None:
    out = tmp_path / "qs"
    result = invoke("quickstart", "--out", out, "--objects", "2", "--repeats", "1", "--workers", "1", "--no-train")
    assert result.exit_code == 0, result.output
    for n, stage in enumerate(("simulate", "preview", "benchmark", "baselines"), 1):
        assert f"[{n}/4] {stage}" in result.stdout
    assert len((out / "sim" / "manifest.jsonl").read_text().splitlines()) == 2
    assert_pngs([out / "preview" / f"mini_apple_{kind}_0{suffix}.png"
                 for kind in ("real", "fake") for suffix in ("", "_signals")])
    assert "data stages finished" in result.stdout and not (out / "train").exists() and not (out / "llm").exists()


def test_quickstart_stops_at_the_first_failing_stage_with_one_error_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def simulation(*args: object, **kwargs: object) -> None:
        raise ValueError("simulation broke")

    monkeypatch.setattr("tacreasoner.sim.run.run_simulation", simulation)
    result = invoke("quickstart", "--out", tmp_path / "qs", "--objects", "2", "--repeats", "1", "--no-train")
    assert_one_line_error(result, "simulation broke")
    assert "[2/4]" not in result.stdout


def test_quickstart_refuses_an_llm_folder_that_is_not_a_model_before_any_work(tmp_path: Path) -> None:
    result = invoke("quickstart", "--out", tmp_path / "qs", "--llm", tmp_path / "nothing")
    assert_one_line_error(result, "--llm", "config.json")
    assert not (tmp_path / "qs").exists()


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


@pytest.mark.parametrize(("preset", "expected"), [(None, "False"), ("0", "True")])
def test_piped_commands_turn_off_library_progress_bars(preset: str | None, expected: str) -> None:
    """A command whose stderr is a pipe or a file turns off transformers' tqdm bars (they fill logs with carriage
    returns) before transformers is imported; a user's own HF_HUB_DISABLE_PROGRESS_BARS wins."""
    code = ("from tacreasoner.cli.app import quiet_library_bars; quiet_library_bars(); "
            "from transformers.utils import logging; print(logging.is_progress_bar_enabled())")
    env = {k: v for k, v in os.environ.items() if k != "HF_HUB_DISABLE_PROGRESS_BARS"}
    if preset is not None:
        env["HF_HUB_DISABLE_PROGRESS_BARS"] = preset
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == expected
