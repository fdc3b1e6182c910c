"""TacReasonerProcessor: placeholder expansion, token roles, batching, save/load, and a full ask round trip."""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
import torch

from tacreasoner.data.clip import TactileClip
from tacreasoner.model.configuration import TacReasonerConfig
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM, TactileAnswer
from tacreasoner.model.processing import IGNORE_INDEX, OPTION_MASK_OFFSET, TacReasonerProcessor, option_spans
from tacreasoner.model.tokenizer import TACTILE_PAD, train_tokenizer
from tacreasoner.tasks.answers import OPTION_MARKER
from tests.model.tinymodel import TEXT_CONFIG

ENCODER = TactileEncoderConfig(num_frames=4, image_size=(32, 32), patch_size=8, hidden_size=32, num_layers=1,
                               num_heads=2, temporal_hidden_size=32, temporal_tokens=2, fusion_heads=2,
                               tokens_per_video=3)
TEXTS = ["Is the first object harder than the second? <think>The first one dents less.</think><answer>yes</answer>",
         "Which object is more elastic? The sponge springs back after release."] * 20


@pytest.fixture(scope="module")
def processor() -> TacReasonerProcessor:
    return TacReasonerProcessor.for_encoder(train_tokenizer(TEXTS, vocab_size=400),
                                            ENCODER.replace(option_marker=OPTION_MARKER))


def _clip(seed: int, sensor: str = "mini") -> TactileClip:
    frames = np.random.default_rng(seed).integers(0, 255, (10, 24, 32, 3), dtype=np.uint8)
    return TactileClip(clip_id=f"c{seed}", object_id=f"o{seed}", fps=25, frames_in_memory=frames, sensor=sensor)


def test_prompt_expands_each_placeholder_and_preprocesses_each_video(processor) -> None:
    inputs = processor.prompt("Compare <tactile> and <tactile>: which is harder?", [_clip(0), _clip(1, "digit@30")])
    ids = inputs["input_ids"][0]
    assert int((ids == processor.tactile_token_id).sum()) == 2 * 3
    assert inputs["pixel_values"].shape == (2, 4, 3, 32, 32)
    assert inputs["sensor_ids"].tolist() == [1, 2]
    text = processor.tokenizer.decode(ids)
    assert text.endswith("<|im_start|>assistant\n") and text.count(TACTILE_PAD) == 6


def test_example_labels_only_the_answer_and_masks_the_question(processor) -> None:
    answer = "<think>It dents less.</think><answer>yes</answer>"
    ex = processor.example("Is <tactile> hard?", answer, [_clip(2)], system="Be brief.")
    tok = processor.tokenizer
    labelled = [i for i in ex["labels"] if i != IGNORE_INDEX]
    assert tok.decode(labelled) == answer + "<|im_end|>"
    question = [i for i, m in zip(ex["input_ids"], ex["question_mask"], strict=True) if m]
    assert tok.decode(question).replace(" ", "") == "Is hard?".replace(" ", "")
    assert processor.tactile_token_id not in question


@pytest.mark.parametrize(("text", "names"), [
    ("The objects are (A) kitchen sponge (B) fake apple (C) wooden block. Pair every video.",
     ["kitchen sponge", "fake apple", "wooden block"]),
    ("Match them to: (A) steel block, (B) folded towel, or (C) real peach? Answer 1-X.",
     ["steel block", "folded towel", "real peach"]),
    ("Options: (A) the first object (B) the second object\nAnswer with A or B.",
     ["the first object", "the second object"]),
    ("(A) sponge (C) towel.", []),  # not A, B, … in order
    ("Pick (A) sponge.", []),  # one option is no list
    ("Is (A) harder than (B) ?", []),  # an empty name is no list
])
def test_option_spans_find_the_names_a_question_lists(text: str, names: list[str]) -> None:
    assert [text[a:b] for a, b in option_spans(text, OPTION_MARKER)] == names


def test_options_are_read_only_with_a_marker_from_config(processor) -> None:
    """The model package knows no benchmark format: without ``encoder.option_marker`` nothing is an option."""
    question = "<tactile> <tactile>\nWhich is which: (A) kitchen sponge (B) harder object? Answer 1-X."
    plain = TacReasonerProcessor.for_encoder(processor.tokenizer, ENCODER.replace(option_marker=""))
    enc = plain.encode_conversation(plain.messages(question), add_generation_prompt=True)
    assert set(enc.question_mask) == {0, 1}
    numbered = TacReasonerProcessor.for_encoder(processor.tokenizer, ENCODER.replace(option_marker=r"\[(\d)\]"))
    enc = numbered.encode_conversation(numbered.messages("<tactile> <tactile>\nPick [1] kitchen sponge [2] fake "
                                                         "apple."), add_generation_prompt=True)
    assert max(enc.question_mask) == OPTION_MASK_OFFSET + 1


def test_question_mask_marks_each_listed_option_s_name(processor) -> None:
    question = "<tactile> <tactile>\nWhich is which: (A) kitchen sponge (B) harder object? Answer 1-X."
    enc = processor.encode_conversation(processor.messages(question, "<answer>1-A, 2-B</answer>"),
                                        add_generation_prompt=False)
    tok = processor.tokenizer
    for k, name in enumerate(["kitchen sponge", "harder object"]):
        marked = [i for i, m in zip(enc.input_ids, enc.question_mask, strict=True) if m == OPTION_MASK_OFFSET + k]
        assert tok.decode(marked).strip() == name
    plain = [i for i, m in zip(enc.input_ids, enc.question_mask, strict=True) if m == 1]
    assert "Which is which" in tok.decode(plain) and "sponge" not in tok.decode(plain)
    assert max(enc.question_mask) == OPTION_MASK_OFFSET + 1
    # no options listed: the mask is 0/1 as before
    assert set(processor.encode_conversation(processor.messages("Is <tactile> hard?"),
                                             add_generation_prompt=True).question_mask) == {0, 1}


def test_placeholder_and_video_counts_must_match(processor) -> None:
    with pytest.raises(ValueError, match=r"1 <tactile> placeholder\(s\) but 2 video\(s\)"):
        processor.prompt("Is <tactile> hard?", [_clip(0), _clip(1)])
    with pytest.raises(ValueError, match=r"0 <tactile> placeholder\(s\) but 1 video"):
        processor.example("Is it hard?", "yes", [_clip(0)])
    with pytest.raises(ValueError, match="internal token"):
        processor.prompt(f"Is {TACTILE_PAD} hard?", [])


def test_collate_pads_right_for_training_and_concatenates_videos(processor) -> None:
    a = processor.example("Is <tactile> hard?", "<answer>yes</answer>", [_clip(0)])
    b = processor.example("Which is softer, <tactile> or <tactile>? Think it over.", "<answer>first</answer>",
                          [_clip(1), _clip(2)])
    batch = processor.collate([a, b])
    assert batch["input_ids"].shape[0] == 2 and batch["pixel_values"].shape[0] == 3
    short = len(a["input_ids"])
    assert batch["attention_mask"][0, short:].sum() == 0
    assert (batch["labels"][0, short:] == IGNORE_INDEX).all()


def test_video_labels_name_each_video_of_a_multi_video_prompt_only(processor) -> None:
    labelled = TacReasonerProcessor.for_encoder(processor.tokenizer, ENCODER.replace(video_labels=True))
    pads = TACTILE_PAD * 3
    assert labelled.expand("<tactile>\n<tactile>\nWhich is harder?") == \
        f"Video 1: {pads}\nVideo 2: {pads}\nWhich is harder?"
    assert labelled.expand("Is <tactile> hard?") == processor.expand("Is <tactile> hard?") == f"Is {pads} hard?"
    assert processor.expand("<tactile> or <tactile>?") == f"{pads} or {pads}?"
    given = "Video 1: <tactile>\nVideo 2: <tactile>\nMatch them."  # a question that names them already
    assert labelled.expand(given) == f"Video 1: {pads}\nVideo 2: {pads}\nMatch them."
    ex = labelled.example("<tactile> or <tactile>?", "<answer>first</answer>", [_clip(0), _clip(1)])
    question = [i for i, m in zip(ex["input_ids"], ex["question_mask"], strict=True) if m]
    assert labelled.tokenizer.decode(question).replace(" ", "") == "Video1:orVideo2:?"  # labels are question text
    labelled.save_pretrained(labelled_dir := Path(tempfile.mkdtemp()))
    assert TacReasonerProcessor.from_pretrained(labelled_dir).video_labels is True
    with pytest.raises(ValueError, match="video_labels must be true or false"):
        ENCODER.replace(video_labels="yes")


def test_save_and_load_round_trip(processor, tmp_path) -> None:
    processor.save_pretrained(tmp_path)
    again = TacReasonerProcessor.from_pretrained(tmp_path)
    assert again.to_dict() == processor.to_dict()
    q = "Is <tactile> hard?"
    assert torch.equal(again.prompt(q, [_clip(3)])["input_ids"], processor.prompt(q, [_clip(3)])["input_ids"])
    (tmp_path / "processor_config.json").write_text('{"video": {}, "frames": 3}')
    with pytest.raises(ValueError, match=r"unknown keys \['frames'\]"):
        TacReasonerProcessor.from_pretrained(tmp_path)


def test_the_vocabulary_is_saved_only_when_known(processor, tmp_path) -> None:
    from tacreasoner.serve.stepwise import model_vocabulary

    processor.save_pretrained(tmp_path)
    assert "vocabulary" not in (tmp_path / "processor_config.json").read_text()
    assert model_vocabulary(tmp_path) == "physiclear", "a folder saved before it was recorded"
    processor.vocabulary = "vtv150k"
    processor.save_pretrained(tmp_path)
    assert TacReasonerProcessor.from_pretrained(tmp_path).vocabulary == "vtv150k"
    assert model_vocabulary(tmp_path) == "vtv150k" and model_vocabulary(tmp_path / "missing") == "physiclear"


def test_a_recorded_gel_reference_maps_what_the_saved_processor_reads(processor, tmp_path) -> None:
    from tacreasoner.model.processing import record_gel_reference
    from tacreasoner.model.video_processing import VideoProcessingConfig

    keep = TacReasonerProcessor(processor.tokenizer, VideoProcessingConfig(num_frames=4, image_size=(32, 32),
                                                                           background="keep"))
    keep.save_pretrained(tmp_path)
    before = keep.prompt("Is <tactile> hard?", [_clip(3)])["pixel_values"]
    reference = {"mean": [0.2, 0.4, 0.4], "std": [0.1, 0.05, 0.1]}
    record_gel_reference(tmp_path, reference)
    loaded = TacReasonerProcessor.from_pretrained(tmp_path)
    assert loaded.video_config.gel_reference == {k: tuple(v) for k, v in reference.items()}
    assert loaded.to_dict()["tokens_per_video"] == keep.to_dict()["tokens_per_video"]  # the rest untouched
    after = loaded.prompt("Is <tactile> hard?", [_clip(3)])["pixel_values"]
    assert after.shape == before.shape and not torch.allclose(after, before), "the map changes what is read"
    record_gel_reference(tmp_path, None)  # removed: frames as trained again
    assert torch.equal(TacReasonerProcessor.from_pretrained(tmp_path).prompt(
        "Is <tactile> hard?", [_clip(3)])["pixel_values"], before)
    processor.save_pretrained(subtracted := tmp_path / "subtract")  # a subtracted frame has no gel colours
    with pytest.raises(ValueError, match=r"processor_config\.json: cannot record gel_reference .*needs background"):
        record_gel_reference(subtracted, reference)


def _model_for(processor: TacReasonerProcessor) -> TacReasonerForCausalLM:
    torch.manual_seed(0)
    config = TacReasonerConfig(text_config={**TEXT_CONFIG, "vocab_size": len(processor.tokenizer)},
                               encoder=ENCODER.to_dict(), tactile_token_id=processor.tactile_token_id)
    return TacReasonerForCausalLM(config).eval()


def test_answer_generates_streams_and_parses(processor) -> None:
    from transformers import TextStreamer

    model = _model_for(processor)
    pieces: list[str] = []

    class Collect(TextStreamer):
        def on_finalized_text(self, text: str, stream_end: bool = False) -> None:
            pieces.append(text)

    reply = model.answer(processor, "Is <tactile> hard?", [_clip(4)], max_new_tokens=6,
                         streamer=Collect(processor.tokenizer, skip_special_tokens=True))
    assert isinstance(reply, TactileAnswer) and isinstance(reply.text, str)
    assert "".join(pieces).strip() == reply.text.strip()
    sampled = model.answer(processor, "Is <tactile> hard?", [_clip(4)], max_new_tokens=6, do_sample=True)
    assert isinstance(sampled.text, str)


def test_auto_processor_loads_from_a_model_directory(processor, tmp_path) -> None:
    _model_for(processor).save_pretrained(tmp_path)
    processor.save_pretrained(tmp_path)
    code = ("import tacreasoner.model\nfrom transformers import AutoProcessor\n"
            f"p = AutoProcessor.from_pretrained({str(tmp_path)!r})\nprint(type(p).__name__, p.tokens_per_video)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[-2:] == ["TacReasonerProcessor", "3"]


def test_build_model_wraps_a_saved_llm_and_its_tokenizer(tmp_path) -> None:
    """A tokenizer without the tactile token (like a real Qwen2.5's) gains it; its rows are Stage I's to train."""
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers
    from transformers import PreTrainedTokenizerFast, Qwen2Config, Qwen2ForCausalLM

    from tacreasoner.model.build import build_model, load_model, save_model

    raw = Tokenizer(models.BPE())
    raw.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    raw.decoder = decoders.ByteLevel()
    raw.train_from_iterator(TEXTS, trainers.BpeTrainer(
        vocab_size=350, special_tokens=["<|endoftext|>", "<|im_start|>", "<|im_end|>"],
        initial_alphabet=pre_tokenizers.ByteLevel.alphabet()))
    plain = PreTrainedTokenizerFast(tokenizer_object=raw, eos_token="<|im_end|>")
    plain.save_pretrained(tmp_path / "llm")
    base = TEXT_CONFIG.copy()
    base.pop("model_type")
    Qwen2ForCausalLM(Qwen2Config(**{**base, "vocab_size": len(plain)})).save_pretrained(tmp_path / "llm")
    model, proc = build_model(tmp_path / "llm", encoder=ENCODER)
    assert len(model.config.new_token_ids) == 5 and proc.tactile_token_id in model.config.new_token_ids
    assert proc.tokens_per_video == ENCODER.tokens_per_video
    assert model.get_input_embeddings().num_embeddings >= len(proc.tokenizer)
    assert proc.tactile_token_id == model.config.tactile_token_id
    save_model(model, proc, tmp_path / "out")
    again, proc2 = load_model(tmp_path / "out")
    inputs = proc2.prompt("Is <tactile> hard?", [_clip(5)])
    with torch.no_grad():
        assert torch.equal(again.eval()(**inputs).logits, model.eval()(**inputs).logits)
    with pytest.raises(FileNotFoundError, match=r"no config\.json"):
        load_model(tmp_path / "llm-missing")
