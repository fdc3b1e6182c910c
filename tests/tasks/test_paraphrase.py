"""Other wordings of the questions: training wordings mixed into training, held-out wordings never trained on and
asked only by the paraphrase evaluation; the two sets never overlap, and an item keeps its gold when re-worded."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tacreasoner.tasks.bench import build_bench, load_bench, reword_bench
from tacreasoner.tasks.paraphrase import (
    PARAPHRASE_DIR,
    check_disjoint,
    heldout_wording_of,
    load_paraphrases,
    normalise,
    reword,
    reword_items,
    trained_wording_of,
)
from tacreasoner.tasks.scoring import score_item
from tacreasoner.tasks.templating import TemplateError, load_templates


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench")
    build_bench("sim", small_sim_dataset, out, seed=0)
    return out


def heldout_texts() -> set[str]:
    return {normalise(p.template.text) for wording in ("heldout", "heldout2")
            for kind in load_paraphrases(wording).values() for p in kind}


def test_heldout_wordings_are_never_training_wordings() -> None:
    check_disjoint()
    trained = {normalise(t.text) for kind in load_templates().values() for t in kind}
    trained |= {normalise(p.template.text) for kind in load_paraphrases("train").values() for p in kind}
    assert heldout_texts() and not heldout_texts() & trained
    # the user's question from the issue is a held-out wording, so answering it is generalisation, not recall
    assert normalise("<tactile>\nIs this object soft or hard?") in heldout_texts()
    first = {normalise(p.template.text) for kind in load_paraphrases("heldout").values() for p in kind}
    second = {normalise(p.template.text) for kind in load_paraphrases("heldout2").values() for p in kind}
    assert second and not first & second, "the second held-out set repeats none of the first"


def test_a_heldout_wording_copied_into_training_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "paraphrases"
    shutil.copytree(PARAPHRASE_DIR, folder)
    text = (folder / "heldout.yaml").read_text()
    (folder / "heldout.yaml").write_text(text.replace("Would you call", "Is it fair to call"))
    check_disjoint(str(folder))  # a new wording is fine
    train = (folder / "train.yaml").read_text()
    (folder / "train.yaml").write_text(train + '\npc:\n  - id: tr_copy\n    text: "Two touches: <tactile> and '
                                               '<tactile>\\nRelative to the second object, is the first one\'s '
                                               '{attribute} more, less or similar?"\n')
    load_paraphrases.cache_clear()
    try:
        with pytest.raises(TemplateError, match="also used for training"):
            check_disjoint(str(folder))
    finally:
        load_paraphrases.cache_clear()


def test_rewording_keeps_the_gold_and_the_answer(bench: Path) -> None:
    _, items = load_bench(bench, "val")
    tfa = next(i for i in items if i.task == "TFA-hardness")
    new = reword(tfa, "heldout")
    assert new is not None and new.question != tfa.question and new.answer == tfa.answer
    assert heldout_wording_of(new.question) == new.meta["template"] and heldout_wording_of(tfa.question) is None
    assert score_item(new, f"<answer>{tfa.answer}</answer>").correct
    assert reword(tfa, "heldout") == new  # deterministic
    # every TFA item of the split gets a wording, and the attribute-specific ones only their own attribute's
    for item in reword_items([i for i in items if i.task.startswith("TFA-")], "heldout"):
        chosen = item.meta["template"]
        spec = next(p for kind in load_paraphrases("heldout").values() for p in kind if p.template.id == chosen)
        assert spec.attribute in (None, item.gold.get("attribute"))


def test_lettered_training_wordings_answer_with_the_letter(bench: Path) -> None:
    _, items = load_bench(bench, "train")
    lettered = [r for r in (reword(i, "train", salt=str(k)) for i in items if i.task in ("SFD", "SOI")
                            for k in range(8)) if r is not None and r.meta["answer_form"] == "letter"]
    assert lettered
    for item in lettered:
        assert item.answer == "ABC"[item.gold["index"]] and "(A) the first object" in item.question
    no_letters = [reword(i, "train", salt=str(k), letters=False) for i in items if i.task == "SOI" for k in range(8)]
    assert all(r is None or r.meta["answer_form"] == "text" for r in no_letters)


def test_training_examples_never_hold_a_heldout_wording(bench: Path) -> None:
    from tacreasoner.train.data import load_examples

    plain = load_examples(2, bench, stage2_data="plain")
    mixed = load_examples(2, bench, stage2_data="plain", paraphrases=True)
    assert len(mixed) > len(plain)
    assert all(heldout_wording_of(e.question) is None for e in mixed)
    # the check would see one: the val split re-worded is caught on every item
    _, val = load_bench(bench, "val")
    assert all(heldout_wording_of(i.question) is not None for wording in ("heldout", "heldout2")
               for i in reword_items(val, wording))
    assert any(e.target == "<answer>B</answer>" for e in mixed)  # a lettered SFD/SOI answer
    assert len({e.question for e in mixed}) > 1.5 * len({e.question for e in plain})
    stage1 = load_examples(1, bench, paraphrases=True)
    assert all(heldout_wording_of(e.question) is None for e in stage1)


def test_wording_checks_read_the_sets_once_not_per_question(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every training question is checked against ~1000 held-out wordings: re-reading the 18 sets per question
    (a cache of 8 sets) made that check 1.5 s a question and one test 23 minutes."""
    import re

    import tacreasoner.tasks.paraphrase as paraphrase

    def filled(text: str) -> str:
        return re.sub(r"\{[a-z_]+\}", "hardness", text)

    heldout = filled(next(iter(load_paraphrases("heldout18").values()))[0].template.text)
    trained = filled(next(iter(load_templates().values()))[0].text)
    assert heldout_wording_of(heldout) is not None and trained_wording_of(trained) is not None  # read, compiled
    parsed: list[Path] = []
    monkeypatch.setattr(paraphrase, "_parse", lambda path: parsed.append(path) or {})
    for _ in range(3):
        assert heldout_wording_of(heldout) is not None and heldout_wording_of(trained) is None
        assert trained_wording_of(trained) is not None and trained_wording_of(heldout) is None
    assert parsed == []


def test_reword_bench_writes_evaluation_splits_only(bench: Path, tmp_path: Path) -> None:
    out = tmp_path / "heldout"
    counts = reword_bench(bench, out)
    assert set(counts) == {"val", "test"} and not (out / "train.jsonl").exists()
    _, items = load_bench(out, "val")
    assert items and all(heldout_wording_of(i.question) == i.meta["template"] for i in items)
    assert all(i.id.endswith("-heldout") for i in items)
    with pytest.raises(ValueError, match="train split is never re-worded"):
        reword_bench(bench, tmp_path / "x", splits=("train",))
