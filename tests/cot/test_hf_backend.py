"""The local Hugging Face teacher on a tiny random Qwen2-architecture model saved to disk (no download)."""

from __future__ import annotations

import asyncio
import threading
import time
from pathlib import Path

import pytest
import torch
import transformers

from tacreasoner.cot.backends import Teacher, TeacherConfig, make_teacher
from tacreasoner.cot.hf_backend import HFTeacher
from tacreasoner.cot.schema import Prompt

CHAT_TEMPLATE = (
    "{% for message in messages %}<|im_start|>{{ message['role'] }}\n{{ message['content'] }}<|im_end|>\n"
    "{% endfor %}{% if add_generation_prompt %}<|im_start|>assistant\n{% endif %}"
)
SPECIALS = ["<|endoftext|>", "<|im_start|>", "<|im_end|>"]
CORPUS = [
    "The sponge is soft: during press the contact area grows fast and the imprint relaxes while holding.",
    "A stone is hard. Sliding shows little shear; after release no residual imprint remains.",
    "<think>press hold slide release</think><answer>the first object</answer>",
    "System: User: Assistant: How hard is the object? Answer: soft, hard, moderately deformable.",
]
PROMPT = Prompt(system="You explain tactile readings.", user="How hard is the object in <tactile>?",
                version="touchcot-test", task="TFA-hardness")


def _save_tiny_model(path: Path, *, chat_template: bool) -> Path:
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers

    raw = Tokenizer(models.BPE())
    raw.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
    raw.decoder = decoders.ByteLevel()
    trainer = trainers.BpeTrainer(vocab_size=300, special_tokens=SPECIALS,
                                  initial_alphabet=pre_tokenizers.ByteLevel.alphabet())
    raw.train_from_iterator(CORPUS * 4, trainer=trainer)
    tokenizer = transformers.PreTrainedTokenizerFast(tokenizer_object=raw, eos_token="<|im_end|>",
                                                     pad_token="<|endoftext|>")
    if chat_template:
        tokenizer.chat_template = CHAT_TEMPLATE
    tokenizer.save_pretrained(path)
    config = transformers.Qwen2Config(
        vocab_size=len(tokenizer), hidden_size=32, intermediate_size=64, num_hidden_layers=2, num_attention_heads=2,
        num_key_value_heads=2, max_position_embeddings=512, eos_token_id=tokenizer.eos_token_id,
        pad_token_id=tokenizer.pad_token_id, tie_word_embeddings=True,
    )
    torch.manual_seed(0)
    transformers.Qwen2ForCausalLM(config).save_pretrained(path)
    return path


@pytest.fixture(scope="module")
def tiny_model_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _save_tiny_model(tmp_path_factory.mktemp("tiny_qwen2_chat"), chat_template=True)


def _teacher(path: Path, **overrides) -> HFTeacher:
    settings = {"backend": "hf", "model": str(path), "temperature": 0.0, "max_tokens": 12,
                "extra": {"device": "cpu", "min_new_tokens": 4}, **overrides}
    teacher = make_teacher(TeacherConfig.from_dict(settings))
    assert isinstance(teacher, HFTeacher)
    return teacher


def test_generates_text_with_token_counts(tiny_model_dir: Path) -> None:
    teacher = _teacher(tiny_model_dir)
    assert isinstance(teacher, Teacher) and (teacher.name, teacher.model) == ("hf", str(tiny_model_dir))
    assert (tiny_model_dir / "model.safetensors").exists()
    reply = asyncio.run(teacher.generate(None, PROMPT))
    assert isinstance(reply.text, str) and reply.text
    assert reply.prompt_tokens > 0 and 4 <= reply.completion_tokens <= 12
    assert reply.cost_usd == 0.0 and reply.model == str(tiny_model_dir)
    ids = teacher.prompt_ids(PROMPT)[0].tolist()
    assert ids.count(teacher._tokenizer.convert_tokens_to_ids("<|im_start|>")) == 3  # system, user, assistant
    summary = teacher.usage.summary()
    assert summary["requests"] == 1 and summary["completion_tokens"] == reply.completion_tokens


def test_greedy_is_deterministic(tiny_model_dir: Path) -> None:
    teacher = _teacher(tiny_model_dir)
    first, second = (asyncio.run(teacher.generate(None, PROMPT)) for _ in range(2))
    assert first.text == second.text


def test_plain_prompt_without_chat_template(tmp_path: Path) -> None:
    path = _save_tiny_model(tmp_path / "plain", chat_template=False)
    teacher = _teacher(path, temperature=0.8, extra={"device": "cpu", "seed": 1, "top_p": 0.9})
    decoded = teacher._tokenizer.decode(teacher.prompt_ids(PROMPT)[0])
    assert decoded.startswith("System: You explain") and decoded.endswith("Assistant:")
    reply = asyncio.run(teacher.generate(None, PROMPT))
    assert reply.completion_tokens > 0


def test_generation_does_not_block_the_event_loop(tiny_model_dir: Path) -> None:
    teacher = _teacher(tiny_model_dir, max_tokens=48, extra={"device": "cpu", "min_new_tokens": 48})
    in_flight = 0
    max_in_flight = 0
    lock = threading.Lock()
    real_generate = teacher._model.generate

    def tracked_generate(*args, **kwargs):
        nonlocal in_flight, max_in_flight
        with lock:
            in_flight += 1
            max_in_flight = max(max_in_flight, in_flight)
        try:
            time.sleep(0.05)  # long enough for the loop to show it is free
            return real_generate(*args, **kwargs)
        finally:
            with lock:
                in_flight -= 1

    teacher._model.generate = tracked_generate

    async def main():
        ticks = 0
        done = asyncio.Event()

        async def ticker() -> None:
            nonlocal ticks
            while not done.is_set():
                ticks += 1
                await asyncio.sleep(0.005)

        tick_task = asyncio.create_task(ticker())
        replies = await asyncio.gather(teacher.generate(None, PROMPT), teacher.generate(None, PROMPT))
        done.set()
        await tick_task
        return replies, ticks

    replies, ticks = asyncio.run(main())
    assert all(r.completion_tokens == 48 for r in replies)
    assert ticks >= 10  # the loop kept running while the model generated in a worker thread
    assert max_in_flight == 1  # one generation at a time


def test_bad_model_path_is_a_one_line_error(tmp_path: Path) -> None:
    with pytest.raises(ValueError) as excinfo:
        make_teacher(TeacherConfig(backend="hf", model=str(tmp_path / "nope"), extra={"device": "cpu"}))
    assert "nope" in str(excinfo.value) and "\n" not in str(excinfo.value)


def test_bad_dtype(tiny_model_dir: Path) -> None:
    with pytest.raises(ValueError, match="dtype"):
        _teacher(tiny_model_dir, extra={"device": "cpu", "dtype": "float8"})
