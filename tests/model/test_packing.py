"""Packed training rows (model/packing.py): fewer positions, the same loss and gradients as the padded batch."""

from __future__ import annotations

import pytest
import torch

from tacreasoner.model.packing import pack_rows, shared_prefix_length
from tests.model.tinymodel import TACTILE_ID, batch, prompt, tiny_model, videos

SYSTEM = [5, 6, 7, 8]
"""A system prompt every sample starts with, as the chat template gives."""


def _training_batch() -> tuple[dict[str, torch.Tensor], torch.Tensor]:
    prompts = [SYSTEM + prompt(1, question=[11, 12]), SYSTEM + prompt(2, question=[13, 14, 15, 16]),
               SYSTEM + prompt(1, question=[17])]
    inputs = batch(prompts)
    labels = inputs["input_ids"].clone()
    labels[inputs["attention_mask"] == 0] = -100
    for row, p in enumerate(prompts):
        labels[row, :len(p) - 2] = -100  # the answer: each prompt's last two tokens
    return inputs, labels


def _decoder_positions(model: torch.nn.Module) -> list[int]:
    seen: list[int] = []

    def note(_module: torch.nn.Module, _args: tuple, kwargs: dict) -> None:
        seen.append(int(kwargs["inputs_embeds"].shape[:2].numel()))

    model.language_model.get_decoder().register_forward_pre_hook(note, with_kwargs=True)
    return seen


@pytest.mark.parametrize("attention", ["eager", "sdpa"])
def test_packed_rows_give_the_padded_loss_and_gradients_on_fewer_positions(attention: str) -> None:
    model = tiny_model(text={"attn_implementation": attention}).train()
    positions = _decoder_positions(model)
    inputs, labels = _training_batch()
    results = []
    for pack in (False, True):
        model.zero_grad()
        out = model(**inputs, pixel_values=videos(4), labels=labels, loss_only=True, pack=pack,
                    num_items_in_batch=6.0)
        out.loss.backward()
        results.append((out.loss.detach(), {n: p.grad.clone() for n, p in model.named_parameters()
                                            if p.grad is not None}))
    (padded, padded_grads), (packed, packed_grads) = results
    real = int(inputs["attention_mask"].sum())
    assert positions[0] == inputs["input_ids"].numel()
    assert positions[1] == real - 2 * len(SYSTEM)  # no padding, and the shared system prompt once instead of 3 times
    assert torch.allclose(packed, padded, atol=1e-6)
    assert packed_grads.keys() == padded_grads.keys() and packed_grads
    for name, grad in padded_grads.items():
        assert torch.allclose(packed_grads[name], grad, atol=1e-6, rtol=1e-5), name


def test_the_shared_prefix_ends_where_samples_differ_or_a_clip_or_a_label_begins() -> None:
    inputs, labels = _training_batch()
    embeds = torch.nn.Embedding(300, 8)(inputs["input_ids"])
    targets = torch.nn.functional.pad(labels, (0, 1), value=-100)[:, 1:]
    mask = inputs["attention_mask"]
    assert shared_prefix_length(embeds, mask, targets) == len(SYSTEM)
    not_tactile = inputs["input_ids"] != TACTILE_ID
    assert shared_prefix_length(embeds, mask, targets, not_tactile) == len(SYSTEM)
    shorter = not_tactile.clone()
    shorter[1, 2] = False  # one sample's third token may not be shared
    assert shared_prefix_length(embeds, mask, targets, shorter) == 2
    labelled = targets.clone()
    labelled[0, 1] = 7  # a loss on the second token: that position is each sample's own
    assert shared_prefix_length(embeds, mask, labelled) == 1


def test_rows_hold_at_most_row_tokens_each_start_with_the_prefix_and_see_only_their_sample() -> None:
    inputs, labels = _training_batch()
    embeds = torch.randn(*inputs["input_ids"].shape, 8)
    embeds[:, :len(SYSTEM)] = embeds[0, :len(SYSTEM)]
    targets = torch.nn.functional.pad(labels, (0, 1), value=-100)[:, 1:]
    lengths = inputs["attention_mask"].sum(1).tolist()
    own = [n - len(SYSTEM) for n in lengths]
    two = pack_rows(embeds, inputs["attention_mask"], targets, row_tokens=len(SYSTEM) + own[1] + own[2])
    assert two is not None and two.inputs_embeds.shape[:2] == (2, len(SYSTEM) + own[1] + own[2])  # 0 | 1 and 2
    packed = pack_rows(embeds, inputs["attention_mask"], targets, row_tokens=1)  # a row never holds less than one
    assert packed is not None and packed.inputs_embeds.shape[:2] == (3, max(lengths))
    assert packed.targets.ne(-100).sum() == targets.ne(-100).sum()
    for r, n in enumerate(lengths):
        assert torch.equal(packed.inputs_embeds[r, :len(SYSTEM)], embeds[0, :len(SYSTEM)])
        assert torch.equal(packed.inputs_embeds[r, len(SYSTEM):n], embeds[r, len(SYSTEM):n])
        assert packed.position_ids[r, :n].tolist() == list(range(n))
    together = pack_rows(embeds, inputs["attention_mask"], targets)
    assert together is not None and together.inputs_embeds.shape[:2] == (1, len(SYSTEM) + sum(own))
    allowed = together.attention_mask[0, 0] == 0
    first_own = len(SYSTEM)  # sample 0's first own token; sample 1's comes after sample 0's
    second_own = len(SYSTEM) + own[0]
    assert allowed[second_own, :len(SYSTEM)].all() and not allowed[second_own, first_own:second_own].any()
    assert allowed[second_own, second_own] and not allowed[first_own, first_own + 1]


def test_a_left_padded_batch_is_not_packed() -> None:
    inputs, labels = _training_batch()
    mask = inputs["attention_mask"].flip(1)
    assert pack_rows(torch.randn(*mask.shape, 8), mask, labels) is None
