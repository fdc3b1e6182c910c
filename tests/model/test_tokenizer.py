"""The project's own small tokenizer (ChatML template, single-token specials and tags) and prepare_tokenizer on any
tokenizer."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.model.tokenizer import (
    CHAT_TEMPLATE,
    END_OF_TEXT,
    IM_END,
    IM_START,
    REASONING_TAGS,
    TACTILE_PAD,
    prepare_tokenizer,
    train_tokenizer,
)

TEXTS = [
    "A real apple is moderately hard. A steel block is extremely hard.",
    "<|im_start|>user\nIs a steel block harder than a real peach?<|im_end|>\n<|im_start|>assistant\n"
    "<think>A steel block is extremely hard. A real peach is soft.</think><answer>yes</answer><|im_end|>\n",
] * 20

DIALOGUES = [
    [{"role": "user", "content": "Is it hard?"}, {"role": "assistant", "content": "<think>It is.</think><answer>yes"
                                                                                     "</answer>"}],
    [{"role": "system", "content": "Be brief."}, {"role": "user", "content": "Hi"},
     {"role": "assistant", "content": "Hello"}, {"role": "user", "content": "Soft or hard?"},
     {"role": "assistant", "content": "<think>x</think><answer>soft</answer>"}],
]


@pytest.fixture(scope="module")
def tokenizer():
    return train_tokenizer(TEXTS, vocab_size=400)


@pytest.mark.parametrize("messages", DIALOGUES)
def test_chat_template_prefix_plus_answer_is_the_full_rendering(tokenizer, messages) -> None:
    prefix = tokenizer.apply_chat_template(messages[:-1], tokenize=False, add_generation_prompt=True)
    full = tokenizer.apply_chat_template(messages, tokenize=False)
    assert prefix + messages[-1]["content"] + "<|im_end|>\n" == full
    assert prefix.endswith("<|im_start|>assistant\n")
    assert full == "".join(f"<|im_start|>{m['role']}\n{m['content']}<|im_end|>\n" for m in messages)  # ChatML


def test_template_has_no_default_system_message_and_marks_assistant_tokens(tokenizer) -> None:
    messages = DIALOGUES[0]
    assert tokenizer.apply_chat_template(messages, tokenize=False).startswith("<|im_start|>user\n")
    out = tokenizer.apply_chat_template(messages, return_assistant_tokens_mask=True, return_dict=True)
    ids, mask = out["input_ids"], out["assistant_masks"]
    answer = [i for i, m in zip(ids, mask, strict=True) if m]
    assert tokenizer.decode(answer) == messages[-1]["content"] + IM_END


def test_special_tokens_and_tags_are_single_ids(tokenizer) -> None:
    for token in (END_OF_TEXT, IM_START, IM_END, TACTILE_PAD, *REASONING_TAGS):
        assert len(tokenizer.encode(token, add_special_tokens=False)) == 1, token
    assert tokenizer.eos_token == IM_END and tokenizer.pad_token == END_OF_TEXT
    assert tokenizer.bos_token is None
    text = f"{IM_START}x{TACTILE_PAD}<think>a</think><answer>b</answer>{IM_END}"
    assert tokenizer.decode(tokenizer.encode(text), skip_special_tokens=True) == "x<think>a</think><answer>b</answer>"


def test_byte_level_encodes_anything(tokenizer) -> None:
    text = "Ünïcödé 🍊 tangerine\n\ttabs"
    assert tokenizer.decode(tokenizer.encode(text)) == text


def test_save_and_load(tokenizer, tmp_path: Path) -> None:
    from transformers import AutoTokenizer

    tokenizer.save_pretrained(tmp_path)
    loaded = AutoTokenizer.from_pretrained(tmp_path)
    assert loaded.chat_template == CHAT_TEMPLATE
    assert loaded.encode(TEXTS[1]) == tokenizer.encode(TEXTS[1])
    assert loaded.model_max_length == tokenizer.model_max_length == 2048
    assert prepare_tokenizer(loaded) == 0


def _bare_tokenizer(pad: bool):
    """A tokenizer like a base Qwen one: ChatML tokens, but no tactile pad, tags, template (or pad)."""
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers
    from transformers import PreTrainedTokenizerFast

    tok = Tokenizer(models.BPE())
    tok.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    tok.decoder = decoders.ByteLevel()
    tok.train_from_iterator(TEXTS, trainers.BpeTrainer(vocab_size=300, special_tokens=[END_OF_TEXT, IM_START, IM_END],
                                                        initial_alphabet=pre_tokenizers.ByteLevel.alphabet()))
    extra = {"pad_token": END_OF_TEXT} if pad else {}
    return PreTrainedTokenizerFast(tokenizer_object=tok, eos_token=IM_END, **extra)


@pytest.mark.parametrize("pad", [True, False])
def test_prepare_tokenizer_adds_what_is_missing_once(pad: bool) -> None:
    tok = _bare_tokenizer(pad)
    size = len(tok)
    assert not tok.chat_template
    added = prepare_tokenizer(tok)
    assert added == 1 + len(REASONING_TAGS) == len(tok) - size
    assert tok.chat_template == CHAT_TEMPLATE
    assert tok.pad_token == END_OF_TEXT
    for token in (TACTILE_PAD, *REASONING_TAGS):
        assert len(tok.encode(token, add_special_tokens=False)) == 1
    assert TACTILE_PAD in tok.all_special_tokens
    assert tok.decode(tok.encode(f"<think>a</think>{TACTILE_PAD}"), skip_special_tokens=True) == "<think>a</think>"
    assert prepare_tokenizer(tok) == 0 and len(tok) == size + added


def test_prepare_tokenizer_keeps_an_existing_template_and_specials(tokenizer) -> None:
    tok = _bare_tokenizer(pad=True)
    tok.add_special_tokens({"additional_special_tokens": [IM_START]})
    tok.chat_template = "{{ messages[0]['content'] }}"
    prepare_tokenizer(tok)
    assert tok.chat_template == "{{ messages[0]['content'] }}"
    assert IM_START in tok.all_special_tokens and TACTILE_PAD in tok.all_special_tokens


def test_train_tokenizer_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="vocab_size"):
        train_tokenizer(TEXTS, vocab_size=100)
    with pytest.raises(ValueError, match="no training texts"):
        train_tokenizer([], vocab_size=400)
    with pytest.raises(ValueError, match="#1 is int"):
        train_tokenizer(["a", 3], vocab_size=400)  # type: ignore[list-item]
