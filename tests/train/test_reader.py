"""Where the clip reader's labels come from: the benchmark's train split only."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.train.trainsetup import training_inputs


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return training_inputs(small_sim_dataset, tmp_path_factory)


def test_clip_labels_gather_each_train_clip_traits_from_its_single_clip_items(inputs) -> None:
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.head_settings import READER_TRAITS
    from tacreasoner.train.reader import clip_labels, item_traits

    labels = clip_labels(inputs["bench"])
    _, items = load_bench(inputs["bench"], "train")
    tfa = [i for i in items if i.task == "TFA-hardness"]
    assert tfa and labels
    for item in tfa:
        row = next(v for k, v in labels.items() if k[0].endswith(item.videos[0].path) and k[1] is None)
        assert row[READER_TRAITS.index("hardness")] == item.gold["level"]
    test_clips = {v.clip_id for i in load_bench(inputs["bench"], "test")[1] for v in i.videos}
    assert not any(Path(k[0]).stem in test_clips for k in labels), "a test clip reached the reader's labels"
    assert item_traits(next(i for i in items if i.task in ("SFD", "SOI"))) == {}
