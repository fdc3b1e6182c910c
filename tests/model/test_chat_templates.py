"""Any chat template: the assistant's end-of-turn marker is labelled and stops generation, whatever it is.

Each tokenizer here is a tiny byte-level BPE saved to disk with one template family's markers as special tokens
and a template written in that family's layout (ChatML, Llama-3, Gemma), then loaded and prepared the way the
project prepares a real LLM's tokenizer (``prepare_tokenizer``).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from transformers import AutoTokenizer, PreTrainedTokenizerFast

from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.processing import IGNORE_INDEX, SYSTEM_FOLD_SEPARATOR, TacReasonerProcessor
from tacreasoner.model.tokenizer import CHAT_TEMPLATE, prepare_tokenizer

ENCODER = TactileEncoderConfig(num_frames=4, image_size=(32, 32), patch_size=8, hidden_size=32, num_layers=1,
                               num_heads=2, temporal_hidden_size=32, temporal_tokens=2, fusion_heads=2,
                               tokens_per_video=3)
TEXTS = ["Is the first object harder than the second? <think>The first one dents less.</think><answer>yes</answer>",
         "Which object is more elastic? The sponge springs back after release. Be brief."] * 20
QUESTION = "Is <tactile> hard?"
ANSWER = "<think>It dents less.</think><answer>yes</answer>"
SYSTEM = "Be brief."

# Llama-3 layout: a header per turn, <|eot_id|> closes every turn; the content is trimmed.
LLAMA3 = (
    "{{- bos_token -}}"
    "{%- for m in messages -%}"
    "{{- '<|start_header_id|>' + m['role'] + '<|end_header_id|>\\n\\n' + (m['content'] | trim) + '<|eot_id|>' -}}"
    "{%- endfor -%}"
    "{%- if add_generation_prompt -%}{{- '<|start_header_id|>assistant<|end_header_id|>\\n\\n' -}}{%- endif -%}"
)
# Gemma layout: no system role (it raises), strict user/model alternation, <end_of_turn> then a newline.
GEMMA = (
    "{{- bos_token -}}"
    "{%- for m in messages -%}"
    "{%- if m['role'] == 'system' -%}{{- raise_exception('System role not supported') -}}{%- endif -%}"
    "{%- if (m['role'] == 'user') != (loop.index0 % 2 == 0) -%}"
    "{{- raise_exception('Conversation roles must alternate user/assistant/user/assistant/...') -}}{%- endif -%}"
    "{{- '<start_of_turn>' + ('model' if m['role'] == 'assistant' else m['role']) + '\\n' -}}"
    "{{- (m['content'] | trim) + '<end_of_turn>\\n' -}}"
    "{%- endfor -%}"
    "{%- if add_generation_prompt -%}{{- '<start_of_turn>model\\n' -}}{%- endif -%}"
)
# name: (special tokens, eos, bos, template or None for the project's ChatML fallback, end-of-turn marker)
FAMILIES = {
    "chatml": (["<|endoftext|>", "<|im_start|>", "<|im_end|>"], "<|endoftext|>", None, None, "<|im_end|>"),
    "llama3": (["<|begin_of_text|>", "<|end_of_text|>", "<|start_header_id|>", "<|end_header_id|>", "<|eot_id|>"],
               "<|end_of_text|>", "<|begin_of_text|>", LLAMA3, "<|eot_id|>"),
    "gemma": (["<pad>", "<eos>", "<bos>", "<start_of_turn>", "<end_of_turn>"], "<eos>", "<bos>", GEMMA,
              "<end_of_turn>"),
}


def _saved_tokenizer(directory: Path, family: str) -> Path:
    """A byte-level BPE with ``family``'s special tokens and template, saved like a downloaded LLM's."""
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers

    specials, eos, bos, template, _ = FAMILIES[family]
    raw = Tokenizer(models.BPE())
    raw.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    raw.decoder = decoders.ByteLevel()
    raw.train_from_iterator(TEXTS, trainers.BpeTrainer(vocab_size=360, special_tokens=specials,
                                                       initial_alphabet=pre_tokenizers.ByteLevel.alphabet()))
    fast = PreTrainedTokenizerFast(tokenizer_object=raw, eos_token=eos, bos_token=bos,
                                   clean_up_tokenization_spaces=False)
    if template is not None:
        fast.chat_template = template
    fast.save_pretrained(directory)
    return directory


def _processor(tmp_path: Path, family: str, system_prompt: str | None = None) -> TacReasonerProcessor:
    tokenizer = AutoTokenizer.from_pretrained(_saved_tokenizer(tmp_path / family, family))
    assert prepare_tokenizer(tokenizer) > 0
    return TacReasonerProcessor.for_encoder(tokenizer, ENCODER, system_prompt=system_prompt)


def _labelled_text(processor: TacReasonerProcessor, input_ids: list[int], labels: list[int]) -> list[str]:
    """The labelled tokens, as one string per contiguous labelled run."""
    runs: list[list[int]] = []
    inside = False
    for token, label in zip(input_ids, labels, strict=True):
        if label != IGNORE_INDEX:
            assert label == token
            if not inside:
                runs.append([])
            runs[-1].append(token)
        inside = label != IGNORE_INDEX
    return [processor.tokenizer.decode(run) for run in runs]


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_labels_cover_the_answer_and_the_template_s_end_of_turn_and_nothing_else(tmp_path, family: str) -> None:
    processor = _processor(tmp_path, family)
    marker = FAMILIES[family][-1]
    if family == "chatml":
        assert processor.tokenizer.chat_template == CHAT_TEMPLATE  # prepare_tokenizer's fallback
    enc = processor.encode_conversation(processor.messages(QUESTION, ANSWER), add_generation_prompt=False)
    assert _labelled_text(processor, enc.input_ids, enc.labels) == [ANSWER + marker]
    marker_id = processor.tokenizer.convert_tokens_to_ids(marker)
    labelled = [t for t, lab in zip(enc.input_ids, enc.labels, strict=True) if lab != IGNORE_INDEX]
    assert labelled[-1] == marker_id and labelled.count(marker_id) == 1
    assert all(lab == IGNORE_INDEX for lab, m in zip(enc.labels, enc.question_mask, strict=True) if m)
    question = [t for t, m in zip(enc.input_ids, enc.question_mask, strict=True) if m]
    assert processor.tokenizer.decode(question).replace(" ", "") == "Ishard?"


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_eos_token_ids_hold_the_template_s_end_of_turn_and_the_eos(tmp_path, family: str) -> None:
    processor = _processor(tmp_path, family)
    tok = processor.tokenizer
    marker_id = tok.convert_tokens_to_ids(FAMILIES[family][-1])
    assert processor.eos_token_ids == sorted({marker_id, tok.eos_token_id})
    assert processor.eos_token_ids == processor.eos_token_ids  # cached, still a fresh list each time
    assert processor.eos_token_ids is not processor.eos_token_ids


def test_every_assistant_turn_of_a_multi_turn_conversation_is_labelled_with_its_end(tmp_path) -> None:
    processor = _processor(tmp_path, "llama3")
    messages = [{"role": "user", "content": QUESTION}, {"role": "assistant", "content": "<answer>yes</answer>"},
                {"role": "user", "content": "Why?"}, {"role": "assistant", "content": " It dents less. "}]
    enc = processor.encode_conversation(messages, add_generation_prompt=False)
    assert _labelled_text(processor, enc.input_ids, enc.labels) == ["<answer>yes</answer><|eot_id|>",
                                                                    "It dents less.<|eot_id|>"]


def test_a_template_without_system_role_gets_the_system_prompt_folded_into_the_user_turn(tmp_path) -> None:
    processor = _processor(tmp_path, "gemma", system_prompt=SYSTEM)
    enc = processor.encode_conversation(processor.messages(QUESTION, ANSWER), add_generation_prompt=False)
    assert not processor.template_takes_system
    text = processor.tokenizer.decode(enc.input_ids)
    assert text.startswith(f"<bos><start_of_turn>user\n{SYSTEM}{SYSTEM_FOLD_SEPARATOR}")
    assert _labelled_text(processor, enc.input_ids, enc.labels) == [ANSWER + "<end_of_turn>"]
    question = [t for t, m in zip(enc.input_ids, enc.question_mask, strict=True) if m]
    assert processor.tokenizer.decode(question).replace(" ", "") == "Ishard?"  # the system text is no question
    prompt = processor.encode_conversation(processor.messages(QUESTION), add_generation_prompt=True)
    assert processor.tokenizer.decode(prompt.input_ids).endswith("<start_of_turn>model\n")
    assert _processor(tmp_path / "chatml", "chatml", system_prompt=SYSTEM).template_takes_system


def test_a_template_that_fails_for_another_reason_says_so(tmp_path) -> None:
    processor = _processor(tmp_path, "gemma", system_prompt=SYSTEM)
    two_users = [{"role": "user", "content": "Hi."}, {"role": "user", "content": QUESTION}]
    with pytest.raises(ValueError, match=r"chat template cannot render this conversation \(roles: user, user\): "
                                         r"Conversation roles must alternate"):
        processor.encode_conversation(two_users, add_generation_prompt=True)
    with pytest.raises(ValueError, match="no user turn follows the system text"):
        processor.encode_conversation([{"role": "system", "content": SYSTEM}], add_generation_prompt=True)
