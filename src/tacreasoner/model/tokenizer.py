"""The project's tokens on any tokenizer (``prepare_tokenizer``), and a small ChatML tokenizer of its own.

``prepare_tokenizer`` adds the tactile placeholder, the reasoning tags and a chat template to a pretrained
tokenizer (SmolLM2's, Qwen2.5's). ``train_tokenizer`` trains a byte-level BPE with the same special tokens and
template on given text (e.g. the package's question, reasoning and prompt wording, ``wording_texts``): a real
tokenizer in milliseconds for tests and examples that must not download one. The special tokens and the template
follow Qwen2.5 conventions, so both take the same downstream path.

Conventions (same as Qwen2.5-Instruct): ``eos_token`` = ``<|im_end|>`` (generation stops at the end of
the assistant turn), ``pad_token`` = ``<|endoftext|>``, no BOS token.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

__all__ = ["CHAT_TEMPLATE", "END_OF_TEXT", "IM_END", "IM_START", "REASONING_TAGS", "TACTILE_PAD",
           "prepare_tokenizer", "train_tokenizer", "wording_texts"]

TACTILE_PAD = "<|tactile_pad|>"
"""One tactile embedding slot: the processor expands each ``<tactile>`` placeholder to N of these."""
IM_START = "<|im_start|>"
IM_END = "<|im_end|>"
END_OF_TEXT = "<|endoftext|>"
REASONING_TAGS = ("<think>", "</think>", "<answer>", "</answer>")
"""Plain (non-special) single tokens: they must survive ``decode(skip_special_tokens=True)``."""

SPECIAL_TOKENS = (END_OF_TEXT, IM_START, IM_END, TACTILE_PAD)
MODEL_MAX_LENGTH = 2048

# Qwen2.5's ChatML without its default system message. Message content may be a string or a list of
# parts ({"type": "text", "text": …}; any other part, e.g. a video, renders as the <tactile>
# placeholder the processor expands). {% generation %} marks assistant turns for
# ``apply_chat_template(..., return_assistant_tokens_mask=True)``.
CHAT_TEMPLATE = (
    "{%- for message in messages -%}"
    "{{- '<|im_start|>' + message['role'] + '\\n' -}}"
    "{%- if message['role'] == 'assistant' -%}{%- generation -%}"
    "{%- if message['content'] is string -%}{{- message['content'] -}}"
    "{%- else -%}{%- for part in message['content'] -%}"
    "{%- if part['type'] == 'text' -%}{{- part['text'] -}}{%- else -%}{{- '<tactile>' -}}{%- endif -%}"
    "{%- endfor -%}{%- endif -%}"
    "{{- '<|im_end|>' -}}{%- endgeneration -%}{{- '\\n' -}}"
    "{%- else -%}"
    "{%- if message['content'] is string -%}{{- message['content'] -}}"
    "{%- else -%}{%- for part in message['content'] -%}"
    "{%- if part['type'] == 'text' -%}{{- part['text'] -}}{%- else -%}{{- '<tactile>' -}}{%- endif -%}"
    "{%- endfor -%}{%- endif -%}"
    "{{- '<|im_end|>\\n' -}}"
    "{%- endif -%}"
    "{%- endfor -%}"
    "{%- if add_generation_prompt -%}{{- '<|im_start|>assistant\\n' -}}{%- endif -%}"
)

_PACKAGE = Path(__file__).resolve().parent.parent
_WORDING_FILES = ("tasks/templates/*.yaml", "tasks/scenarios.yaml", "cot/rules_bank.yaml", "cot/prompts/*.yaml")


def _batches(texts: Iterable[str], size: int = 1000) -> Iterator[list[str]]:
    batch: list[str] = []
    for i, text in enumerate(texts):
        if not isinstance(text, str):
            raise ValueError(f"tokenizer training text #{i} is {type(text).__name__}, not str")
        batch.append(text)
        if len(batch) == size:
            yield batch
            batch = []
    if batch:
        yield batch


def train_tokenizer(texts: Iterable[str], vocab_size: int = 4096) -> Any:
    """A byte-level BPE ``PreTrainedTokenizerFast`` trained on ``texts`` (ChatML tokens, template, tags).

    Byte-level means no unknown tokens: any text (a user's question about an unseen object) still
    encodes. The vocabulary can end up smaller than ``vocab_size`` when the texts run out of merges.
    """
    from tokenizers import AddedToken, Tokenizer, decoders, models, pre_tokenizers, trainers
    from transformers import PreTrainedTokenizerFast

    minimum = len(pre_tokenizers.ByteLevel.alphabet()) + len(SPECIAL_TOKENS) + len(REASONING_TAGS)
    if vocab_size < minimum:
        raise ValueError(f"vocab_size must be at least {minimum} (256 bytes + special tokens), got {vocab_size}")
    tok = Tokenizer(models.BPE())
    tok.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    tok.decoder = decoders.ByteLevel()
    trainer = trainers.BpeTrainer(
        vocab_size=vocab_size - len(REASONING_TAGS), min_frequency=2, show_progress=False,
        special_tokens=list(SPECIAL_TOKENS), initial_alphabet=pre_tokenizers.ByteLevel.alphabet(),
    )
    seen = 0

    def counted() -> Iterator[list[str]]:
        nonlocal seen
        for batch in _batches(texts):
            seen += len(batch)
            yield batch

    tok.train_from_iterator(counted(), trainer=trainer)
    if seen == 0:
        raise ValueError("train_tokenizer: no training texts given")
    tok.add_tokens([AddedToken(t, special=False, normalized=False) for t in REASONING_TAGS])
    fast = PreTrainedTokenizerFast(
        tokenizer_object=tok, eos_token=IM_END, pad_token=END_OF_TEXT, model_max_length=MODEL_MAX_LENGTH,
        padding_side="right", clean_up_tokenization_spaces=False,
    )
    fast.add_special_tokens({"additional_special_tokens": [IM_START, TACTILE_PAD]})
    fast.chat_template = CHAT_TEMPLATE
    return fast


def _has_token(tokenizer: Any, text: str) -> bool:
    """``text`` is already one token of ``tokenizer`` (special or not)."""
    ids = tokenizer.convert_tokens_to_ids([text])
    return bool(ids) and ids[0] is not None and ids[0] != tokenizer.unk_token_id \
        and tokenizer.convert_ids_to_tokens(ids[0]) == text


def prepare_tokenizer(tokenizer: Any) -> int:
    """Make any Hugging Face tokenizer ready for TacReasoner; returns how many tokens were added.

    Adds ``TACTILE_PAD`` as a special token and the reasoning tags as plain tokens when missing, sets
    the ChatML template when the tokenizer has none and a pad token when it lacks one. Idempotent. The
    model must resize its embeddings when the return value is not 0.
    """
    before = len(tokenizer)
    if not _has_token(tokenizer, TACTILE_PAD):
        # The full list (old + new): the keyword that keeps existing extras differs across transformers versions.
        extras = getattr(tokenizer, "extra_special_tokens", None) or getattr(tokenizer, "additional_special_tokens", [])
        extras = list(extras) if isinstance(extras, list | tuple) else []
        tokenizer.add_special_tokens({"additional_special_tokens": [*map(str, extras), TACTILE_PAD]})
    from tokenizers import AddedToken

    missing = [t for t in REASONING_TAGS if not _has_token(tokenizer, t)]
    if missing:
        tokenizer.add_tokens([AddedToken(t, special=False, normalized=False) for t in missing])
    if not getattr(tokenizer, "chat_template", None):
        tokenizer.chat_template = CHAT_TEMPLATE
    if tokenizer.pad_token is None:
        if _has_token(tokenizer, END_OF_TEXT):
            tokenizer.pad_token = END_OF_TEXT
        elif tokenizer.eos_token is not None:
            tokenizer.pad_token = tokenizer.eos_token
        else:
            tokenizer.add_special_tokens({"pad_token": END_OF_TEXT})
    return len(tokenizer) - before


def wording_texts() -> list[str]:
    """The package's question, scenario, reasoning and prompt wording files, as text."""
    texts = []
    for pattern in _WORDING_FILES:
        paths = sorted(_PACKAGE.glob(pattern))
        if not paths:
            raise FileNotFoundError(f"{_PACKAGE / pattern}: package wording files missing (broken install?)")
        texts += [p.read_text(encoding="utf-8") for p in paths]
    return texts
