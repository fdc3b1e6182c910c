"""The removed-touch control: blank and shuffled tactile input to predict_items, the evaluate --touch flag, and the
control's table and run (tacreasoner.evaluate.touch_control, published by benchmarks/touch_control.py)."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
import torch
from typer.testing import CliRunner

from tacreasoner.evaluate import touch_control
from tacreasoner.evaluate.predict import (
    TOUCH_MODES,
    blank_video,
    check_touch,
    load_trained,
    predict_items,
    predictions_path,
    set_aside_stale,
    shuffle_videos,
)
from tacreasoner.tasks.bench import BENCH_VERSION, load_bench
from tacreasoner.tasks.schema import QAItem
from tacreasoner.train.data import bench_video_root, video_key


@pytest.fixture(scope="module")
def loaded(model_dir: Path) -> tuple[Any, Any]:
    return load_trained(model_dir, device="cpu")


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("touch_video_cache")


@pytest.fixture(scope="module")
def chosen(bench: Path) -> tuple[Path, list[QAItem]]:
    """Single-clip and two-clip test items of two held-out objects: the video root and the items."""
    info, items = load_bench(bench, "test")
    picked = [i for i in items if i.task in ("TFA-hardness", "TFA-friction", "SFD")]
    assert any(len(i.videos) == 2 for i in picked) and any(len(i.videos) == 1 for i in picked)
    return bench_video_root(bench, info), picked


def _run(loaded: tuple[Any, Any], chosen: tuple[Path, list[QAItem]], out: Path, cache: Path, touch: str,
         seed: int = 0) -> dict[str, dict[str, Any]]:
    """Item id → its prediction line and the generate inputs of its row (its pixel values, sensor ids; the other
    inputs of its call), from a spy on the model's generate (the model still answers)."""
    model, processor = loaded
    root, items = chosen
    rows: list[dict[str, Any]] = []
    real = model.generate

    def spy(**kwargs: Any) -> torch.Tensor:
        per_row = (kwargs["input_ids"] == processor.tactile_token_id).sum(1) // processor.tokens_per_video
        assert int(per_row.sum()) == len(kwargs["pixel_values"]) == len(kwargs["sensor_ids"])
        inputs = {k: v for k, v in kwargs.items() if isinstance(v, torch.Tensor)}
        pixels, sensors = kwargs["pixel_values"].split(per_row.tolist()), kwargs["sensor_ids"].split(per_row.tolist())
        rows.extend({**inputs, "pixel_values": p.clone(), "sensor_ids": s.clone()}
                    for p, s in zip(pixels, sensors, strict=True))
        return real(**kwargs)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(model, "generate", spy)
        predict_items(model, processor, items, root, out, max_new_tokens=1, video_cache=cache, touch=touch,
                      touch_seed=seed)
    lines = [json.loads(line) for line in out.read_text().splitlines()]
    assert len(lines) == len(rows) == len(items)
    return {line["id"]: {**row, "line": line} for line, row in zip(lines, rows, strict=True)}


@pytest.fixture(scope="module")
def real_run(loaded, chosen, cache, tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    return _run(loaded, chosen, tmp_path_factory.mktemp("touch_real") / "real.jsonl", cache, "real")


# ------------------------------------------------------------------------------------------ modes and shuffle


def test_unknown_touch_names_the_allowed_ones(tmp_path: Path) -> None:
    assert TOUCH_MODES == ("real", "blank", "shuffled")
    with pytest.raises(ValueError, match=r"real, blank, shuffled.*'none'"):
        check_touch("none")
    with pytest.raises(ValueError, match="real, blank, shuffled"):
        predict_items(None, None, [], tmp_path, tmp_path / "p.jsonl", touch="Blank")
    assert not (tmp_path / "p.jsonl").exists()
    assert predictions_path(tmp_path, "test") == tmp_path / "predictions" / "test.jsonl"
    assert predictions_path(tmp_path, "val", "shuffled") == tmp_path / "predictions" / "val_shuffled.jsonl"


def _keys(spec: dict[str, list[str]]) -> dict[str, list[tuple[str, None, None]]]:
    return {item: [(f"/clips/{c}.mp4", None, None) for c in clips] for item, clips in spec.items()}


def test_shuffle_is_seeded_keeps_counts_and_never_returns_an_items_own_clip() -> None:
    # clips shared between items, as the benchmark's TFA items share them
    spec = {f"q{n}": [f"c{n % 7}"] for n in range(20)} | {f"pair{n}": [f"c{n}", f"c{n + 1}"] for n in range(5)}
    keys = _keys(spec)
    a, b, other = shuffle_videos(keys, 3), shuffle_videos(keys, 3), shuffle_videos(keys, 4)
    assert a == b and a != other
    assert list(a) == list(keys)
    assert all(len(a[i]) == len(keys[i]) for i in keys)
    assert Counter(k for v in a.values() for k in v) == Counter(k for v in keys.values() for k in v)
    for shuffled in (a, other):
        assert all(not {k[0] for k in shuffled[i]} & {k[0] for k in keys[i]} for i in keys)


def test_shuffle_avoids_an_items_own_objects_where_it_can() -> None:
    # two clips per object: a plain derangement of clips would often hand an item its object's other clip
    spec = {f"i{n}": [f"{obj}_{n % 2}"] for n, obj in enumerate(["a", "a", "b", "b", "c", "c", "d", "d"] * 2)}
    objects = {item: [clips[0].split("_")[0]] for item, clips in spec.items()}
    for seed in range(5):
        out = shuffle_videos(_keys(spec), seed, objects)
        got = {item: Path(v[0][0]).stem.split("_")[0] for item, v in out.items()}
        assert all(got[item] != objects[item][0] for item in spec), (seed, got)


def test_shuffle_of_one_item_keeps_its_videos() -> None:
    keys = _keys({"only": ["x", "y", "z"]})
    out = shuffle_videos(keys, 0)
    assert sorted(out["only"]) == sorted(keys["only"])  # nothing else to give it: the best there is


def test_shuffle_of_the_benchmark_split_moves_every_single_clip_item_to_another_object(
        chosen: tuple[Path, list[QAItem]]) -> None:
    root, items = chosen
    keys = {i.id: [video_key(v, root, i.id) for v in i.videos] for i in items}
    out = shuffle_videos(keys, 0, {i.id: i.objects for i in items})
    for item in items:
        assert not {k[0] for k in out[item.id]} & {k[0] for k in keys[item.id]}
        if len(item.videos) == 1:  # the split has two objects: a single clip can always get the other one
            assert Path(out[item.id][0][0]).stem.rsplit("_", 1)[0] not in item.objects


# ------------------------------------------------------------------------------------------ what the model sees


def test_blank_gives_every_item_the_same_zero_clips_and_keeps_sensor_ids(loaded, chosen, cache, real_run, tmp_path,
                                                                          monkeypatch) -> None:
    from tacreasoner.train.data import VideoBank

    real = real_run
    # a bank holding cached ViT tokens of the real clips: they must not reach the model
    batch = VideoBank.batch

    def with_appearance(self: VideoBank, keys: list) -> dict[str, torch.Tensor]:
        out = batch(self, keys)
        return out | {"appearance_tokens": torch.ones(len(keys), 3, 64)}

    monkeypatch.setattr(VideoBank, "batch", with_appearance)
    blank = _run(loaded, chosen, tmp_path / "blank.jsonl", cache, "blank")
    zeros = blank_video(loaded[1].video_config)
    assert torch.equal(zeros, torch.zeros(4, 3, 32, 32))
    for item in chosen[1]:
        seen, own = blank[item.id], real[item.id]
        assert "appearance_tokens" not in seen
        assert seen["pixel_values"].shape == own["pixel_values"].shape == (len(item.videos), 4, 3, 32, 32)
        assert not seen["pixel_values"].any() and own["pixel_values"].abs().sum() > 0
        assert torch.equal(seen["sensor_ids"], own["sensor_ids"])
        assert seen["line"]["touch"] == "blank" and own["line"]["touch"] == "real"
        assert "touch_seed" not in seen["line"]


@pytest.mark.parametrize("touch", ["real", "shuffled"])
def test_cached_appearance_tokens_are_those_of_the_clips_shown(loaded, chosen, cache, tmp_path, touch) -> None:
    """Each clip's frozen appearance tokens are computed once and passed with its pixels: they must be what the
    model would compute from the pixels it is shown (for shuffled touch: the other item's clip, not its own)."""
    model, processor = loaded
    root, items = chosen
    real, calls = model.generate, []

    def spy(**kwargs: Any) -> torch.Tensor:
        shown = model.tactile_encoder.appearance_tokens(kwargs["pixel_values"])
        torch.testing.assert_close(kwargs["appearance_tokens"], shown, atol=1e-5, rtol=1e-4)
        calls.append(len(shown))
        return real(**kwargs)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(model, "generate", spy)
        predict_items(model, processor, items, root, tmp_path / "p.jsonl", max_new_tokens=1, video_cache=cache,
                      touch=touch)
    assert sum(calls) == sum(len(i.videos) for i in items)


def _per_video(runs: dict[str, dict[str, Any]]) -> Counter:
    return Counter(round(float(v.double().sum()), 3) for r in runs.values() for v in r["pixel_values"])


def test_shuffled_gives_items_other_items_clips_deterministically(loaded, chosen, cache, real_run, tmp_path) -> None:
    real = real_run
    first = _run(loaded, chosen, tmp_path / "s0.jsonl", cache, "shuffled", seed=0)
    again = _run(loaded, chosen, tmp_path / "s0_again.jsonl", cache, "shuffled", seed=0)
    other = _run(loaded, chosen, tmp_path / "s1.jsonl", cache, "shuffled", seed=1)
    assert _per_video(first) == _per_video(real)  # the split's videos, each used as often as before
    for item in chosen[1]:
        seen, own = first[item.id], real[item.id]
        assert seen["pixel_values"].shape == own["pixel_values"].shape
        assert not torch.equal(seen["pixel_values"], own["pixel_values"])
        assert seen["line"]["touch"] == "shuffled" and seen["line"]["touch_seed"] == 0
        assert len(seen["line"]["touch_videos"]) == len(item.videos)
        assert not set(seen["line"]["touch_videos"]) & {v.path for v in item.videos}
        assert torch.equal(seen["pixel_values"], again[item.id]["pixel_values"])
    assert any(not torch.equal(first[i]["pixel_values"], other[i]["pixel_values"]) for i in first)
    assert {r["line"]["touch_seed"] for r in other.values()} == {1}


class PixelEcho(torch.nn.Module):
    """A stand-in model whose answer is the sum of the pixel values it is given: shows what each item saw."""

    def __init__(self, tokenizer: Any) -> None:
        super().__init__()
        self.anchor = torch.nn.Parameter(torch.zeros(1))
        self.tokenizer = tokenizer

    def generate(self, input_ids: torch.Tensor, pixel_values: torch.Tensor, **_: Any) -> torch.Tensor:
        ids = self.tokenizer(f"{float(pixel_values.double().abs().sum()):.3f}", add_special_tokens=False).input_ids
        return torch.tensor([ids] * len(input_ids))


def test_predictions_change_with_the_touch_and_modes_are_not_mixed(loaded, chosen, cache, tmp_path) -> None:
    root, items = chosen
    model = PixelEcho(loaded[1].tokenizer)
    answers = {}
    for touch in TOUCH_MODES:
        path = predictions_path(tmp_path, "test", touch)
        predict_items(model, loaded[1], items, root, path, batch_size=1, video_cache=cache, touch=touch)
        lines = [json.loads(line) for line in path.read_text().splitlines()]
        assert {line["touch"] for line in lines} == {touch}
        answers[touch] = {line["id"]: float(line["prediction"]) for line in lines}
    assert all(answers["real"][i] > 0 for i in answers["real"])
    assert set(answers["blank"].values()) == {0.0}
    assert all(answers["shuffled"][i] != answers["real"][i] for i in answers["real"])

    # resuming: the same mode skips what is done; another mode or shuffle seed is refused, not appended
    blank = predictions_path(tmp_path, "test", "blank")
    before = blank.read_text()
    predict_items(model, loaded[1], items, root, blank, video_cache=cache, touch="blank")
    assert blank.read_text() == before
    with pytest.raises(ValueError, match=r"touch=blank, this run asks for touch=shuffled \(touch_seed 0\)"):
        predict_items(model, loaded[1], items, root, blank, video_cache=cache, touch="shuffled")
    with pytest.raises(ValueError, match=r"touch=shuffled \(touch_seed 0\).*touch=shuffled \(touch_seed 2\)"):
        predict_items(model, loaded[1], items, root, predictions_path(tmp_path, "test", "shuffled"),
                      video_cache=cache, touch="shuffled", touch_seed=2)
    assert blank.read_text() == before
    # a file written before the touch field existed holds real-touch answers
    old = tmp_path / "old.jsonl"
    old.write_text("".join(json.dumps({"id": i.id, "prediction": "x", "task": i.task}) + "\n" for i in items))
    predict_items(model, loaded[1], items, root, old, video_cache=cache)
    with pytest.raises(ValueError, match="touch=real, this run asks for touch=blank"):
        predict_items(model, loaded[1], items, root, old, video_cache=cache, touch="blank")


# ------------------------------------------------------------------------------------------ CLI


def test_evaluate_touch_flag_keeps_the_modes_side_by_side(model_dir: Path, bench: Path, tmp_path: Path) -> None:
    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "eval"
    base = ["evaluate", "--model", str(model_dir), "--bench", str(bench), "--out", str(out), "--limit", "3",
            "--max-new-tokens", "2"]
    for touch in (None, "blank", "shuffled"):
        result = runner.invoke(app, base + ([] if touch is None else ["--touch", touch]))
        assert result.exit_code == 0, result.output
    for name, touch in (("val", "real"), ("val_blank", "blank"), ("val_shuffled", "shuffled")):  # val by default
        lines = [json.loads(line) for line in (out / "predictions" / f"{name}.jsonl").read_text().splitlines()]
        assert len(lines) == 3 and {line["touch"] for line in lines} == {touch}
    assert (out / "report.md").is_file()
    assert (out / "touch_blank" / "report.md").is_file() and (out / "touch_shuffled" / "report.md").is_file()
    result = runner.invoke(app, [*base, "--touch", "nothing"])
    assert result.exit_code == 2
    assert "touch must be one of real, blank, shuffled; got 'nothing'" in result.output
    result = runner.invoke(app, [*base, "--dtype", "half"])
    assert result.exit_code == 2
    assert "dtype must be one of float32, bfloat16, auto; got 'half'" in result.output


def test_evaluate_video_cache_is_filled_once_and_answers_as_without_it(model_dir: Path, bench: Path,
                                                                        tmp_path: Path) -> None:
    from tacreasoner.cli import app

    runner = CliRunner()
    cache = tmp_path / "video_cache"
    base = ["evaluate", "--model", str(model_dir), "--bench", str(bench), "--limit", "3", "--max-new-tokens", "2"]
    plain = runner.invoke(app, [*base, "--out", str(tmp_path / "plain")])
    first = runner.invoke(app, [*base, "--out", str(tmp_path / "first"), "--video-cache", str(cache)])
    assert plain.exit_code == 0 and first.exit_code == 0, plain.output + first.output
    files = sorted(cache.glob("*.npy"))
    assert files, "the cache was not filled"
    stamps = {f: f.stat().st_mtime_ns for f in files}
    second = runner.invoke(app, [*base, "--out", str(tmp_path / "second"), "--video-cache", str(cache)])
    assert second.exit_code == 0, second.output
    assert sorted(cache.glob("*.npy")) == files and all(f.stat().st_mtime_ns == stamps[f] for f in files), \
        "a second model answering the same clips decoded them again"

    def answers(name: str) -> list[str]:
        path = tmp_path / name / "predictions" / "val.jsonl"
        return [json.loads(line)["prediction"] for line in path.read_text().splitlines()]

    assert answers("plain") == answers("first") == answers("second")


def test_evaluate_refuses_to_resume_answers_of_another_model_or_benchmark(model_dir: Path, bench: Path,
                                                                          tmp_path: Path) -> None:
    import shutil

    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "eval"
    base = ["evaluate", "--bench", str(bench), "--out", str(out), "--max-new-tokens", "2"]
    assert runner.invoke(app, [*base, "--model", str(model_dir), "--limit", "2"]).exit_code == 0
    lines = [json.loads(line) for line in (out / "predictions" / "val.jsonl").read_text().splitlines()]
    assert all(line["answered_by"].startswith(f"model={model_dir.resolve()} [") and
               line["answered_by"].endswith(f"; bench={bench.resolve()} v{BENCH_VERSION}") for line in lines)
    other = tmp_path / "other_model"
    shutil.copytree(model_dir, other)
    refused = runner.invoke(app, [*base, "--model", str(other), "--limit", "3"])
    assert refused.exit_code == 2 and "predictions made by model=" in refused.output
    assert "rather than mix the two" in refused.output
    resumed = runner.invoke(app, [*base, "--model", str(model_dir), "--limit", "3"])
    assert resumed.exit_code == 0, resumed.output
    assert len((out / "predictions" / "val.jsonl").read_text().splitlines()) == 3, "the same model resumes"


def test_evaluate_refuses_to_resume_answers_prepared_before_a_hand_edit(model_dir: Path, bench: Path,
                                                                         tmp_path: Path) -> None:
    """docs/real-data.md tells owners of old folders to add ``orientation`` by hand: the weights keep their time,
    yet answers made before the edit saw other frames and must not be resumed as the edited model's."""
    import shutil

    from tacreasoner.cli import app
    from tacreasoner.evaluate import predict

    model = shutil.copytree(model_dir, tmp_path / "model")
    runner = CliRunner()
    out = tmp_path / "eval"
    base = ["evaluate", "--bench", str(bench), "--out", str(out), "--max-new-tokens", "2", "--model", str(model)]
    assert runner.invoke(app, [*base, "--limit", "2"]).exit_code == 0
    before = json.loads((out / "predictions" / "val.jsonl").read_text().splitlines()[0])["answered_by"]
    config_path = model / "processor_config.json"
    config = json.loads(config_path.read_text())
    config["video"]["orientation"] = "as_is" if config["video"].get("orientation") == "match" else "match"
    config_path.write_text(json.dumps(config))
    refused = runner.invoke(app, [*base, "--limit", "3"])
    assert refused.exit_code == 2 and "rather than mix the two" in refused.output
    assert predict.answerer_id(model, bench) != before


def test_evaluate_refuses_to_resume_answers_of_another_benchmark_version(model_dir: Path, bench: Path,
                                                                         tmp_path: Path) -> None:
    """A benchmark rebuilt at another version asks other items under the same ids (TSA in version 2)."""
    import shutil

    from tacreasoner.cli import app

    runner = CliRunner()
    copy, out = tmp_path / "bench", tmp_path / "eval"
    shutil.copytree(bench, copy)
    base = ["evaluate", "--bench", str(copy), "--out", str(out), "--max-new-tokens", "2", "--model", str(model_dir)]
    assert runner.invoke(app, [*base, "--limit", "2"]).exit_code == 0
    info = json.loads((copy / "bench.json").read_text())
    (copy / "bench.json").write_text(json.dumps({**info, "version": BENCH_VERSION - 1}))
    refused = runner.invoke(app, [*base, "--limit", "3"])
    assert refused.exit_code == 2 and f"v{BENCH_VERSION}, this run is" in refused.output, refused.output


def test_stale_predictions_are_set_aside_not_resumed(tmp_path: Path) -> None:
    """A re-run after retraining, or after the benchmark was rebuilt at a new version, asks the same ids anew: the old
    answers move aside instead of being scored against the new items."""
    path = tmp_path / "seed0.jsonl"
    assert set_aside_stale(path, "me") is None  # nothing yet
    lines = [{"id": "a", "prediction": "x", "answered_by": "me"}, {"id": "b", "prediction": "y", "answered_by": "me"}]
    path.write_text("".join(json.dumps(r) + "\n" for r in lines) + '{"id": "c", "predic')  # a line cut by a crash
    assert set_aside_stale(path, "me") is None and path.is_file(), "the same answerer resumes"
    moved = set_aside_stale(path, "me v2")
    assert moved == tmp_path / "seed0.stale.jsonl" and not path.exists()
    assert moved.read_text().startswith('{"id": "a"'), "kept, not deleted"
    path.write_text(json.dumps({"id": "a", "prediction": "x"}) + "\n")  # from before answers recorded who made them
    assert set_aside_stale(path, "me") == moved and not path.exists()


# ------------------------------------------------------------------------------- the control's table and run


def _records(task: str, correct: list[bool], prefix: str = "") -> list[dict]:
    return [{"id": f"{prefix}{task}-{n}", "task": task, "correct": c, "parse_failed": not c, "chance": 0.25}
            for n, c in enumerate(correct)]


def test_touch_table_from_scored_records() -> None:
    from tacreasoner.evaluate.stats import mcnemar_exact
    from tacreasoner.intervals import wilson_interval

    real = [True] * 18 + [False] * 2
    blank = [True] * 5 + [False] * 15
    shuffled = [False, True] * 10
    other = [True, False, True, False]
    records = {"real": _records("TFA-hardness", real) + _records("SFD", other),
               "blank": _records("TFA-hardness", blank) + _records("SFD", other),
               "shuffled": _records("TFA-hardness", shuffled) + _records("SFD", other[::-1])}
    table = touch_control.touch_table(records)
    rows = {r["task"]: r for r in table["tasks"]}
    assert list(rows) == ["TFA-hardness", "SFD"]
    hardness = rows["TFA-hardness"]
    assert hardness["n"] == 20 and hardness["chance"] == 0.25
    assert hardness["real"]["accuracy"] == 0.9 and hardness["blank"]["accuracy"] == 0.25
    assert hardness["shuffled"]["accuracy"] == 0.5
    assert (hardness["blank"]["ci_low"], hardness["blank"]["ci_high"]) == pytest.approx(wilson_interval(5, 20))
    assert hardness["real_vs_blank"]["p_value"] == pytest.approx(mcnemar_exact(real, blank).p_value)
    assert hardness["real_vs_blank"]["p_value"] < 0.001
    assert hardness["real_vs_shuffled"]["p_value"] == pytest.approx(mcnemar_exact(real, shuffled).p_value)
    assert rows["SFD"]["real_vs_blank"]["p_value"] == 1.0  # same answers: no discordant pair
    assert table["overall"]["n"] == 24 and table["overall"]["blank"]["accuracy"] == pytest.approx(7 / 24)
    assert table["average"]["real"] == pytest.approx((0.9 + 0.5) / 2)

    md = touch_control.table_markdown(table)
    assert "| TFA-hardness | 20 | 25.0 | 90.0 [" in md and "| SFD | 4 |" in md
    assert "**Overall** (items)" in md and "**Average** (tasks)" in md
    assert f"**{hardness['real_vs_blank']['p_value']:.2g} (" in md  # bold: p < 0.05
    assert "(13↓ 0↑)" in md  # 13 items right with real touch and wrong with blank, none the other way

    with pytest.raises(ValueError, match="missing shuffled"):
        touch_control.touch_table({"real": records["real"], "blank": records["blank"]})
    with pytest.raises(ValueError, match="item sets differ"):
        touch_control.touch_table(records | {"blank": _records("TFA-hardness", blank, prefix="x")})


def test_the_control_runs_the_three_modes_the_predictions_know() -> None:
    assert touch_control.MODES == TOUCH_MODES


def test_touch_control_runs_end_to_end(model_dir: Path, bench: Path, tmp_path: Path) -> None:
    said: list[str] = []
    control = touch_control.run_touch_control(model_dir, bench, "val", tmp_path / "out", limit=4, max_new_tokens=2,
                                              device="cpu", say=said.append)
    averages = [line for line in said if not line.startswith("warning: ")]
    assert [line.split(":")[0] for line in averages] == list(TOUCH_MODES)
    # a 2-token budget cuts the untrained model's noise: the user is told for each mode's file
    assert len(said) - len(averages) == len(TOUCH_MODES)
    payload = json.loads(json.dumps(control.to_dict()))
    assert payload["split"] == "val" and payload["n_items"] == 4 and payload["model"] == str(model_dir)
    assert payload["device"] == "cpu" and set(payload["reports"]) == set(TOUCH_MODES)
    assert sum(r["n"] for r in payload["table"]["tasks"]) == 4
    md = control.markdown()
    assert "p real vs blank" in md and "split **val**" in md and "4 items (--limit)" in md
    for touch in TOUCH_MODES:
        assert predictions_path(tmp_path / "out", "val", touch).is_file()
        assert control.predictions[touch] == predictions_path(tmp_path / "out", "val", touch)
    with pytest.raises(ValueError, match="limit must be at least 1"):
        touch_control.run_touch_control(model_dir, bench, "val", tmp_path / "out", limit=0)


def test_a_finished_predictions_file_is_not_answered_again_and_loads_no_model(model_dir: Path, bench: Path,
                                                                              tmp_path: Path, monkeypatch) -> None:
    """answer_with_model (predict_split's and the quickstart's evaluation) loads the model only for work left."""
    from tacreasoner.evaluate import predict

    info, items = load_bench(bench, "test")
    path = tmp_path / "seed0.jsonl"
    predict.answer_with_model(model_dir, bench, info, items[:2], path, max_new_tokens=2)
    before = path.read_text()
    assert len(before.splitlines()) == 2

    def no_load(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("the model was loaded although every item was answered")

    monkeypatch.setattr(predict, "load_trained", no_load)
    predict.answer_with_model(model_dir, bench, info, items[:2], path, max_new_tokens=2)
    assert path.read_text() == before
    with pytest.raises(AssertionError, match="the model was loaded"):
        predict.answer_with_model(model_dir, bench, info, items[:3], path, max_new_tokens=2)


def test_answering_in_bfloat16_casts_the_weights_and_is_recorded_so_a_float32_resume_does_not_mix(
        model_dir: Path, bench: Path, tmp_path: Path) -> None:
    """--dtype bfloat16 answers with bf16 weights; its lines name the type, so float32 answers never join that file."""
    from tacreasoner.evaluate import predict

    model, _ = predict.load_trained(model_dir, device="cpu", dtype="bfloat16")
    assert {p.dtype for p in model.parameters()} == {torch.bfloat16}
    with pytest.raises(ValueError, match=r"dtype must be one of float32, bfloat16, auto; got 'fp16'"):
        predict.load_trained(model_dir, device="cpu", dtype="fp16")
    info, items = load_bench(bench, "test")
    path = tmp_path / "seed0.jsonl"
    predict.answer_with_model(model_dir, bench, info, items[:2], path, max_new_tokens=2, dtype="bfloat16")
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert len(lines) == 2 and all("dtype=bfloat16" in line["answered_by"] for line in lines)
    assert predict.answerer_id(model_dir, bench, "float32") == predict.answerer_id(model_dir, bench)
    with pytest.raises(ValueError, match=r"this run is .*; write them to another --out"):
        predict.answer_with_model(model_dir, bench, info, items[:3], path, max_new_tokens=2)
