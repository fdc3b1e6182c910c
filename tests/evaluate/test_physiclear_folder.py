"""Scoring a PhysiCLeAR-shaped folder nobody here has seen (Octopi's test objects): a small synthetic folder in its
layout (GelSight-like .mov clips, labels.json), holding only a ``test`` split; the items built from it, the
Octopi-shaped table and bad folders; and one real GelSight Mini clip where ../shared is beside the checkout."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner.evaluate.octopi import OCTOPI_COLUMNS, octopi_table
from tacreasoner.tasks.bench import build_folder_bench, load_bench
from tacreasoner.tasks.scoring import score_item
from tacreasoner.video_io import VideoError
from tests.conftest import write_labelled_folder
from tests.evaluate.evalsetup import save_untrained_model

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "physiclear"
OBJECTS = {  # name → (hardness, roughness, bumpiness), as in PhysiCLeAR's labels.json
    "feather_duster_handle": (2, 0, 0), "steel_wool": (0, 2, 1), "tsa_lock_numbers": (2, 2, 1), "denim": (1, 1, 1),
    "millet": (1, 2, 1),
}


def make_folder(root: Path, split: str = "test", videos: int = 2, extra: dict | None = None) -> Path:
    """labels.json + videos/ with the OBJECTS, all in ``split``, plus ``extra`` (name → (split, ranks)); synthetic
    .mov clips, as PhysiCLeAR ships them."""
    objects = {name: (split, ranks) for name, ranks in OBJECTS.items()} | (extra or {})
    root = write_labelled_folder(root, objects, clips_per_object=videos, ext="mov")
    labels = json.loads((root / "labels.json").read_text())
    (root / "labels.json").write_text(json.dumps({"dataset": "a synthetic copy", **labels}))
    return root


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_folder(tmp_path_factory.mktemp("physiclear_copy"))


def test_a_test_only_folder_builds_octopis_task_set_deterministically(folder: Path, tmp_path: Path) -> None:
    summary, split = build_folder_bench(folder, tmp_path / "a")
    assert split == "test" and summary.objects == {"test": 5}
    assert set(summary.counts["test"]) == {"TFA-hardness", "TFA-roughness", "TFA-bumpiness", "TFA-combined", "SFD",
                                           "PC", "SOI", "OSC", "TSA"}
    info, items = load_bench(tmp_path / "a", "test")
    assert info["folder_split"] == "test" and info["video_root"] == str(folder.resolve())
    assert all(score_item(i, f"<answer>{i.answer}</answer>").correct for i in items)
    assert all((folder / v.path).is_file() for i in items for v in i.videos)
    build_folder_bench(folder, tmp_path / "b")
    assert (tmp_path / "a" / "test.jsonl").read_text() == (tmp_path / "b" / "test.jsonl").read_text()
    summary, _ = build_folder_bench(folder, tmp_path / "c", per_task=7, seed=1)
    assert set(summary.counts["test"].values()) == {7}


def test_any_split_name_is_scored_as_test_and_the_choice_is_explained(tmp_path: Path) -> None:
    heldout = make_folder(tmp_path / "heldout", split="Heldout")
    _, split = build_folder_bench(heldout, tmp_path / "bench")
    assert split == "test" and json.loads((tmp_path / "bench" / "bench.json").read_text())["folder_split"] == "heldout"
    labels = json.loads((heldout / "labels.json").read_text())
    labels["objects"]["denim"]["split"] = "val"
    (heldout / "labels.json").write_text(json.dumps(labels))
    # several labelled splits: val by default (no command reads test objects unless asked)
    assert build_folder_bench(heldout, tmp_path / "d")[1] == "val"
    with pytest.raises(ValueError, match=r"no labelled object has split 'test'; splits present: heldout, val"):
        build_folder_bench(heldout, tmp_path / "x", split="test")
    assert build_folder_bench(heldout, tmp_path / "v", split="val")[1] == "val"
    assert build_folder_bench(heldout, tmp_path / "h", split="heldout")[1] == "test"
    labels["objects"]["denim"]["split"] = "train"
    (heldout / "labels.json").write_text(json.dumps(labels))
    with pytest.raises(ValueError, match=r"labels.json: several labelled splits \(heldout, train\) and none is 'val'"):
        build_folder_bench(heldout, tmp_path / "x")


@pytest.mark.parametrize(("damage", "message"), [
    (lambda d: (d / "labels.json").unlink(), r"labels.json: no PhysiCLeAR labels.json here"),
    (lambda d: (d / "labels.json").write_text("{not json"), r"labels.json: not valid JSON"),
    (lambda d: _edit(d, lambda o: o["denim"].pop("roughness")), r"object 'denim' \(split 'test'\): missing field"),
    (lambda d: _edit(d, lambda o: o["denim"].update(hardness=5)), r"'denim'.*hardness"),
    (lambda d: _edit(d, lambda o: o["denim"].update(videos="denim_0.mov")), r"object 'denim', field 'videos'"),
    (lambda d: (d / "videos" / "denim_1.mov").unlink(), r"denim_1.mov"),
    (lambda d: (d / "videos" / "denim_1.mov").write_bytes(b"not a video"), r"denim_1.mov"),
])
def test_bad_folders_are_one_clear_error_naming_file_and_field(tmp_path: Path, damage, message: str) -> None:
    bad = make_folder(tmp_path / "bad")
    damage(bad)
    with pytest.raises((ValueError, FileNotFoundError, VideoError), match=message) as caught:
        build_folder_bench(bad, tmp_path / "bench")
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "bench" / "test.jsonl").exists(), "nothing written for a bad folder"


def _edit(folder: Path, change) -> None:
    labels = json.loads((folder / "labels.json").read_text())
    change(labels["objects"])
    (folder / "labels.json").write_text(json.dumps(labels))


@pytest.fixture(scope="module")
def model_dir(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An untrained tiny model saved as `train` saves one (its answers are noise; the command is what is tested)."""
    root = tmp_path_factory.mktemp("physiclear_model")
    build_folder_bench(folder, root / "bench")
    return save_untrained_model([f"{i.question} {i.answer}" for i in load_bench(root / "bench", "test")[1]], root,
                                vocab_size=400)


def test_evaluate_physiclear_writes_the_octopi_table(folder: Path, model_dir: Path, tmp_path: Path) -> None:
    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "eval"
    args = ["evaluate-physiclear", "--model", str(model_dir), "--model", str(model_dir), "--data", str(folder),
            "--out", str(out), "--max-new-tokens", "2", "--per-task", "3"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    saved = json.loads((out / "octopi.json").read_text())
    assert saved["split"] == "test" and len(saved["models"]) == 2
    assert [c for c, _ in OCTOPI_COLUMNS] == list(saved["table"])
    assert all(saved["table"][c]["n"] == 3 and saved["table"][c]["runs"] == 2 for c in saved["table"])
    assert saved["table"]["PC"]["chance"] == pytest.approx(1 / 3) and saved["table"]["POM"]["task"] == "OSC"
    md = (out / "octopi.md").read_text()
    assert "| hardness | roughness | bumpiness | combined | PC | PSS | POM | PSR |" in md and "Octopi-13b" in md
    assert (out / "report.md").is_file()
    answered = [(out / f"model{k}" / "predictions" / "test.jsonl").read_text() for k in (0, 1)]
    assert answered[0] == answered[1] and len(answered[0].splitlines()) == 27
    again = runner.invoke(app, args)  # resumable: the answers are kept, not redone
    assert again.exit_code == 0 and (out / "model0" / "predictions" / "test.jsonl").read_text() == answered[0]

    result = runner.invoke(app, [*args[:5], "--data", str(tmp_path / "nowhere"), "--out", str(tmp_path / "eval2")])
    assert result.exit_code == 2 and "labels.json" in result.output and "Traceback" not in result.output


def test_models_added_to_a_scored_folder_are_scored_beside_the_first(folder: Path, model_dir: Path,
                                                                     tmp_path: Path) -> None:
    """A recipe asked for more seeds in the same folder scores them all, keeping the first model's answers."""
    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "eval"
    common = ["--data", str(folder), "--out", str(out), "--max-new-tokens", "2", "--per-task", "2"]
    first = runner.invoke(app, ["evaluate-physiclear", "--model", str(model_dir), *common])
    assert first.exit_code == 0, first.output
    kept = (out / "model0" / "predictions" / "test.jsonl").stat().st_mtime_ns
    more = runner.invoke(app, ["evaluate-physiclear", "--model", str(model_dir), "--model", str(model_dir), *common])
    assert more.exit_code == 0, more.output
    assert json.loads((out / "octopi.json").read_text())["table"]["hardness"]["runs"] == 2
    assert (out / "model0" / "predictions" / "test.jsonl").stat().st_mtime_ns == kept, "model 0 was answered again"
    other = tmp_path / "other_model"
    shutil.copytree(model_dir, other)
    result = runner.invoke(app, ["evaluate-physiclear", "--model", str(other), "--model", str(model_dir), *common])
    assert result.exit_code == 2 and "models changed" in result.output, result.output


def test_octopi_table_leaves_absent_tasks_empty() -> None:
    from tacreasoner.evaluate.report import summarize

    records = [{"id": f"h{k}", "task": "TFA-hardness", "correct": k < 3, "parse_failed": False, "chance": 1 / 3}
               for k in range(4)]
    table = octopi_table(summarize({"run": records}))
    assert table["hardness"]["accuracy"] == 0.75 and table["hardness"]["n"] == 4
    assert table["PC"] is None and table["PSR"] is None


REAL_CLIP = SHARED / "videos" / "denim_0.mov"


@pytest.mark.parametrize("real", [False, pytest.param(True, marks=pytest.mark.skipif(
    not REAL_CLIP.is_file(), reason="PhysiCLeAR is not beside the checkout (../shared/data/physiclear); CI has it"))])
def test_ask_answers_about_a_physiclear_mov_clip(real: bool, folder: Path, model_dir: Path) -> None:
    """The real-data path end to end for one clip: a .mov decoded, encoded and answered (the folder's synthetic one,
    and a real GelSight Mini clip where the shared data is beside the checkout)."""
    from tacreasoner.cli import app

    clip = REAL_CLIP if real else folder / "videos" / "denim_0.mov"
    question = "Here is a tactile video of an object: <tactile>\nHow does its hardness feel?"
    result = CliRunner().invoke(app, ["ask", question, "--video", str(clip), "--model", str(model_dir),
                                      "--max-new-tokens", "4"])
    assert result.exit_code == 0, result.output
    assert "answer:" in result.output
