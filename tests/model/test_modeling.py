"""TacReasonerForCausalLM: shapes, placeholder errors, question conditioning, ablation switches, save/load."""

from __future__ import annotations

import copy
import math
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import torch

from tacreasoner.model.modeling import TacReasonerForCausalLM
from tests.model.tinymodel import ENCODER, TACTILE_ID, TEXT_CONFIG, batch, prompt, tiny_model, videos

TEXT_HIDDEN = TEXT_CONFIG["hidden_size"]


@pytest.mark.parametrize("tokens_per_video", [1, 3])
def test_one_to_three_videos_per_prompt(tokens_per_video: int) -> None:
    model = tiny_model(tokens_per_video=tokens_per_video)
    prompts = [prompt(k, tokens_per_video) for k in (1, 2, 3)]
    inputs = batch(prompts)
    pixel_values = videos(6)
    out = model(**inputs, pixel_values=pixel_values, labels=inputs["input_ids"])
    assert out.logits.shape == (3, inputs["input_ids"].shape[1], 300)
    assert torch.isfinite(out.loss)
    tactile = model.encode_videos(pixel_values, torch.zeros(6, 64))
    assert tactile.shape == (6, tokens_per_video, 64)


@pytest.mark.parametrize("num_items", [None, 7.0])
def test_loss_only_gives_the_full_heads_loss_and_gradients(num_items: float | None) -> None:
    """The training path runs the LM head on labelled positions only; loss and gradients must not change."""
    model = tiny_model()
    inputs = batch([prompt(1), prompt(2), prompt(1)])
    labels = inputs["input_ids"].clone()
    labels[:, :4] = -100  # a prompt part, as in training
    labels[inputs["attention_mask"] == 0] = -100  # padding
    labels[2] = -100  # a row without any label
    extra = {} if num_items is None else {"num_items_in_batch": num_items}
    results = []
    for loss_only in (False, True):
        model.zero_grad()
        out = model(**inputs, pixel_values=videos(4), labels=labels, loss_only=loss_only, **extra)
        out.loss.backward()
        grads = {n: p.grad.clone() for n, p in model.named_parameters() if p.grad is not None}
        results.append((out, grads))
    (full, full_grads), (only, only_grads) = results
    assert only.logits is None and full.logits is not None
    assert torch.allclose(only.loss, full.loss, atol=1e-6)
    assert full_grads.keys() == only_grads.keys() and full_grads
    for name, grad in full_grads.items():
        assert torch.allclose(only_grads[name], grad, atol=1e-6), name


def test_the_cpu_autocast_head_casts_a_frozen_matrix_once_and_again_when_it_changes() -> None:
    """The training loss's LM head keeps its bf16 cast of the frozen output matrix between steps: the logits equal
    the plain head's, a changed matrix is cast anew, and the new tokens' rows still learn."""
    from tacreasoner.model.token_rows import train_token_rows

    model = tiny_model()
    for p in model.parameters():
        p.requires_grad_(False)
    (rows,) = train_token_rows(model.language_model, [296, 297])
    head = model.language_model.get_output_embeddings()
    hidden = torch.randn(5, TEXT_HIDDEN)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        got = model._head(hidden)
        assert got.dtype == torch.bfloat16 and torch.equal(got, head(hidden))
        cast = model.__dict__["_cast_head"][2]
        model._head(hidden)
        assert model.__dict__["_cast_head"][2] is cast  # kept, not cast again
        with torch.no_grad():
            head.weight[5] += 1.0
        again = model._head(hidden)
        assert model.__dict__["_cast_head"][2] is not cast and torch.equal(again, head(hidden))
        again.float().sum().backward()
    assert rows.grad is not None and rows.grad.abs().sum() > 0
    assert "_cast_head" not in model.state_dict() and all("_cast_head" not in n for n, _ in model.named_buffers())


def test_tactile_embeddings_land_on_the_placeholders_in_video_order() -> None:
    model = tiny_model(question_conditioning=False)
    inputs = batch([prompt(1), prompt(2)])
    pixel_values = videos(3)
    embeds = model.embed_inputs(inputs["input_ids"], pixel_values, inputs["attention_mask"])
    expected = model.encode_videos(pixel_values)
    tpv = ENCODER["tokens_per_video"]
    first = (inputs["input_ids"][0] == TACTILE_ID).nonzero().flatten()
    second = (inputs["input_ids"][1] == TACTILE_ID).nonzero().flatten()
    assert torch.allclose(embeds[0, first], expected[0])
    assert torch.allclose(embeds[1, second[:tpv]], expected[1])
    assert torch.allclose(embeds[1, second[tpv:]], expected[2])
    text = model.get_input_embeddings()(inputs["input_ids"])
    keep = inputs["input_ids"] != TACTILE_ID
    assert torch.equal(embeds[keep], text[keep])


def test_placeholder_and_video_mismatch_is_a_clear_error() -> None:
    model = tiny_model()
    inputs = batch([prompt(2)])
    with pytest.raises(ValueError, match=r"2 tactile placeholder\(s\).*but 1 video\(s\)"):
        model(**inputs, pixel_values=videos(1))
    with pytest.raises(ValueError, match=r"but 0 video"):
        model(**inputs)
    broken = batch([[11, TACTILE_ID, TACTILE_ID, 12]])  # a run of 2 with 3 tokens per video
    with pytest.raises(ValueError, match="not a multiple of tokens_per_video=3"):
        model(**broken, pixel_values=videos(1))
    with pytest.raises(ValueError, match="pixel_values must be videos×4×3×32×32"):
        model(**batch([prompt(1)]), pixel_values=torch.zeros(1, 5, 3, 32, 32))


def _tactile_rows(model: TacReasonerForCausalLM, question: list[int]) -> torch.Tensor:
    inputs = batch([prompt(1, question=question)])
    embeds = model.embed_inputs(inputs["input_ids"], videos(1, seed=4), inputs["attention_mask"])
    return embeds[inputs["input_ids"] == TACTILE_ID]


def _train_fusion_a_little(model: TacReasonerForCausalLM) -> None:
    # The fusion FFN starts at zero (appearance passes straight through); give it weights as training would.
    torch.manual_seed(1)
    torch.nn.init.normal_(model.tactile_encoder.fusion.ffn[-1].weight, std=0.2)


def test_the_question_steers_the_temporal_aggregation_only_when_conditioning_is_on() -> None:
    on = tiny_model(question_conditioning=True)
    _train_fusion_a_little(on)
    with torch.no_grad():
        a, b = _tactile_rows(on, [40, 41, 42]), _tactile_rows(on, [90, 91, 92])
    assert not torch.allclose(a, b, atol=1e-5)
    off = tiny_model(question_conditioning=False)
    _train_fusion_a_little(off)
    with torch.no_grad():
        a, b = _tactile_rows(off, [40, 41, 42]), _tactile_rows(off, [90, 91, 92])
    assert torch.equal(a, b)


def test_the_temporal_branch_sees_motion_and_can_be_switched_off() -> None:
    with_temporal = tiny_model()
    _train_fusion_a_little(with_temporal)
    still = videos(1).expand(1, 4, 3, 32, 32).clone()
    still[:, :] = still[:, :1]  # every frame the same: no differences
    moving = still.clone()
    moving[:, 2:] += 0.5
    q = torch.zeros(1, 64)
    with torch.no_grad():
        app_still = with_temporal.tactile_encoder.appearance_tokens(still)
        fused_still = with_temporal.tactile_encoder(still, q)
        fused_moving = with_temporal.tactile_encoder(moving, q)
        app_moving = with_temporal.tactile_encoder.appearance_tokens(moving)
    # what the fusion adds differs when only the motion differs
    assert not torch.allclose(fused_moving - app_moving, fused_still - app_still, atol=1e-5)
    without = tiny_model(use_temporal=False)
    assert without.tactile_encoder.temporal is None and without.tactile_encoder.fusion is None
    assert not any("temporal" in n or "fusion" in n for n, _ in without.named_parameters())
    with torch.no_grad():
        assert torch.equal(without.tactile_encoder(moving), without.tactile_encoder.appearance_tokens(moving))


def test_sensor_embedding_is_optional_and_changes_the_tokens_by_sensor() -> None:
    model = tiny_model(sensor_embedding=True)
    torch.nn.init.normal_(model.tactile_encoder.sensor_embed.weight)
    pv = videos(1).repeat(2, 1, 1, 1, 1)
    with torch.no_grad():
        out = model.tactile_encoder(pv, torch.zeros(2, 64), torch.tensor([1, 2]))
    assert not torch.allclose(out[0], out[1])
    assert tiny_model().tactile_encoder.sensor_embed is None


def test_video_slots_tell_the_same_clip_apart_by_its_place_in_the_prompt() -> None:
    model = tiny_model(question_conditioning=False, video_slots=3)
    tpv = ENCODER["tokens_per_video"]
    same = videos(1).repeat(2, 1, 1, 1, 1)  # one clip shown twice in one prompt
    inputs = batch([prompt(2)])
    places = (inputs["input_ids"][0] == TACTILE_ID).nonzero().flatten()

    def first_and_second() -> tuple[torch.Tensor, torch.Tensor]:
        with torch.no_grad():
            embeds = model.embed_inputs(inputs["input_ids"], same, inputs["attention_mask"])[0]
        return embeds[places[:tpv]], embeds[places[tpv:]]

    first, second = first_and_second()
    assert torch.allclose(first, second, rtol=0, atol=1e-6)  # the slot vectors start at zero: no change until trained
    torch.nn.init.normal_(model.projector.video_slot.shift)
    first, second = first_and_second()
    shift = model.projector.video_slot.shift
    assert torch.allclose(second - first, (shift[1] - shift[0]).expand_as(first), atol=1e-5)
    torch.nn.init.normal_(model.projector.video_slot.mix, std=0.1)
    first_mixed, second_mixed = first_and_second()
    assert not torch.allclose(second_mixed - first_mixed, second - first)  # each place has its own map
    # a video's slot is its place in its own prompt, not in the batch
    two = batch([prompt(1), prompt(1)])
    with torch.no_grad():
        embeds = model.embed_inputs(two["input_ids"], same, two["attention_mask"])
    assert torch.allclose(embeds[0, :tpv + 3], embeds[1, :tpv + 3], rtol=0, atol=1e-6)
    with pytest.raises(ValueError, match=r"holds 4 videos but this model tells at most 3 apart \(encoder.video_slots"):
        model.embed_inputs(batch([prompt(4)])["input_ids"], videos(4))
    assert tiny_model().projector.video_slot is None
    with pytest.raises(ValueError, match="video_slots must be a whole number"):
        tiny_model(video_slots=-1)


def test_cross_video_lets_one_video_depend_on_the_other_videos_of_its_prompt_only() -> None:
    model = tiny_model(cross_video=3)
    tpv = ENCODER["tokens_per_video"]
    inputs = batch([prompt(2), prompt(1)])
    places = (inputs["input_ids"] == TACTILE_ID).nonzero()

    def first_video(pv: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        with torch.no_grad():
            embeds = model.embed_inputs(inputs["input_ids"], pv, inputs["attention_mask"])
        at = places[places[:, 0] == 0][:tpv, 1]
        alone = places[places[:, 0] == 1][:, 1]
        return embeds[0, at], embeds[1, alone]

    pv = videos(3)
    other = pv.clone()
    other[1] = videos(1, seed=5)[0]  # change the second video of the two-video prompt
    assert torch.equal(first_video(pv)[0], first_video(other)[0])  # zero-initialised: no change until trained
    torch.nn.init.normal_(model.projector.cross_video.out.weight, std=0.2)
    (a, alone_a), (b, alone_b) = first_video(pv), first_video(other)
    assert not torch.allclose(a, b)  # the first video's tokens now see the second video
    assert torch.equal(alone_a, alone_b)  # a single-video prompt is left as it was
    with pytest.raises(ValueError, match=r"holds 4 videos but the cross-video layer was built for at most 3"):
        model.embed_inputs(batch([prompt(4)])["input_ids"], videos(4))
    assert tiny_model().projector.cross_video is None
    with pytest.raises(ValueError, match="cross_video must be a whole number"):
        tiny_model(cross_video=-1)


def test_cross_video_comparator_loss_joins_the_lm_loss_only_for_prompts_with_a_pick() -> None:
    model = tiny_model(cross_video=3, cross_video_loss=0.5).train()
    cv = model.projector.cross_video
    inputs = batch([prompt(2), prompt(3), prompt(1)])
    labels = inputs["input_ids"].masked_fill(inputs["input_ids"] == TACTILE_ID, -100)
    pv = videos(6)
    plain = model(**inputs, pixel_values=pv, labels=labels).loss
    none = model(**inputs, pixel_values=pv, labels=labels, video_winner=torch.tensor([-100, -100, -100])).loss
    assert torch.equal(plain, none)
    picked = model(**inputs, pixel_values=pv, labels=labels, video_winner=torch.tensor([1, 2, -100])).loss
    # the directions start at zero, so every video scores alike: cross-entropy ln 2 for the pair, ln 3 for the
    # triple, averaged over the two picks
    expected = plain + 0.5 * (math.log(2) + math.log(3)) / 2
    assert torch.allclose(picked, expected, atol=1e-4)
    picked.backward()
    assert cv.directions.grad.abs().sum() > 0
    # with the attribute (index into cross_video_attributes) and the comparative known, their losses join too
    model.zero_grad()
    targets = torch.tensor([[1, 0, 1], [2, 2, 0], [-100, -100, -100]])
    named = model(**inputs, pixel_values=pv, labels=labels, video_winner=targets).loss
    assert named > picked
    named.backward()
    assert cv.attribute[1].weight.grad.abs().sum() > 0 and cv.comparative[1].weight.grad.abs().sum() > 0
    assert bool((cv.feature_mean != 0).any())  # running statistics move while training
    with pytest.raises(ValueError, match="cross_video_loss must be a number"):
        tiny_model(cross_video=3, cross_video_loss=-1.0)


def _comparisons(n: int, k: int, gen: torch.Generator, tokens: int = 2, hidden: int = 8, question_dim: int = 6
                 ) -> tuple[list[torch.Tensor], torch.Tensor, torch.Tensor]:
    """Prompts of k videos whose attribute a (0 or 1) sits in feature a of token 0, asked by a question vector that
    names the attribute and the way (more/less) in its first three entries, plus noise."""
    feats = [torch.randn(k, tokens, hidden, generator=gen) * 0.5 for _ in range(n)]
    attribute = torch.randint(0, 2, (n,), generator=gen)
    more = torch.randint(0, 2, (n,), generator=gen)
    questions = torch.randn(n, question_dim, generator=gen) * 0.1
    questions[torch.arange(n), attribute] += 1.0
    questions[:, 2] += more * 2.0 - 1.0
    for f, a in zip(feats, attribute.tolist(), strict=True):
        f[:, 0, a] += torch.randn(k, generator=gen) * 2.0
    winner = torch.stack([(f[:, 0, a] if m else -f[:, 0, a]).argmax()
                          for f, a, m in zip(feats, attribute.tolist(), more.tolist(), strict=True)])
    return feats, questions, torch.stack([winner, attribute, more], dim=1)


def test_cross_video_comparator_fit_picks_by_attribute_and_comparative_then_freezes() -> None:
    from tacreasoner.model.heads import CrossVideoFusion

    fusion = CrossVideoFusion(8, 2, 2.0, 3, 6, tokens_per_video=2, attributes=2).train()
    gen = torch.Generator().manual_seed(0)
    train = [_comparisons(60, 2, gen), _comparisons(60, 3, gen)]
    feats = [f for part in train for f in part[0]]
    fitted = fusion.fit(feats, torch.cat([p[1] for p in train]), torch.cat([p[2] for p in train]), steps=300)
    assert fitted["comparisons"] == 120 and fitted["pick"] > 0.9 and fitted["attribute"] == 1.0
    assert all(not p.requires_grad for p in fusion.comparator_parameters)
    stats = fusion.feature_mean.clone()
    torch.testing.assert_close(stats, torch.cat([f.flatten(1) for f in feats]).mean(0))
    # unseen prompts: the fitted comparator picks them too, through the forward pass's scores
    test_feats, test_q, test_gold = _comparisons(50, 2, gen)
    with torch.no_grad():
        scores, _, _ = fusion._compare(fusion._normalised(torch.stack([f.flatten(1) for f in test_feats])), test_q)
    assert (scores.argmax(-1) == test_gold[:, 0]).float().mean() > 0.85
    # a frozen comparator's statistics stay put in training mode
    fusion(torch.cat(test_feats[:4]), torch.tensor([2, 2, 2, 2]), test_q[:4])
    assert torch.equal(fusion.feature_mean, stats)
    with pytest.raises(ValueError, match="at least one comparison"):
        fusion.fit([], torch.zeros(0, 6), torch.zeros(0, 3, dtype=torch.long))


def test_the_comparator_fit_moves_its_directions_as_scoring_through_compare_would() -> None:
    """fit reads each question's attribute and sign once; the directions must end exactly where a loop that scores
    every batch through _compare and _comparison_loss (fit's loop before it was made faster) takes them."""
    from tacreasoner.model.heads import CrossVideoFusion

    gen = torch.Generator().manual_seed(1)
    train = [_comparisons(40, 2, gen), _comparisons(40, 3, gen)]
    feats = [f for part in train for f in part[0]]
    questions, targets = torch.cat([p[1] for p in train]), torch.cat([p[2] for p in train])
    torch.manual_seed(0)
    fast = CrossVideoFusion(8, 2, 2.0, 3, 6, tokens_per_video=2, attributes=2)
    slow = copy.deepcopy(fast)
    fast.fit(feats, questions, targets, steps=60, seed=3)

    slow.fit(feats, questions, targets, steps=0, seed=3)  # the same statistics, ridge heads and zero directions
    groups: dict[int, list[int]] = {}
    for i, f in enumerate(feats):
        groups.setdefault(len(f), []).append(i)
    stacked = {k: (slow._normalised(torch.stack([feats[i].flatten(1) for i in rows])), questions[rows],
                   targets[rows]) for k, rows in groups.items()}
    place = {i: (k, r) for k, rows in groups.items() for r, i in enumerate(rows)}
    slow.directions.requires_grad_(True)
    optimizer = torch.optim.AdamW([slow.directions], lr=1e-2, weight_decay=0.1)
    generator = torch.Generator().manual_seed(3)
    for _ in range(60):
        picked = torch.randint(0, len(feats), (16,), generator=generator).tolist()
        loss = torch.zeros(())
        for k, (f, asked, gold) in stacked.items():
            rows = [place[i][1] for i in picked if place[i][0] == k]
            if rows:
                loss = loss + slow._comparison_loss(*slow._compare(f[rows], asked[rows]), gold[rows, 0])[0]
        optimizer.zero_grad()
        (loss / 16).backward()
        optimizer.step()
    assert fast.directions.abs().sum() > 0
    torch.testing.assert_close(fast.directions, slow.directions.detach(), rtol=0, atol=1e-6)


def test_the_comparator_reads_its_question_from_the_llm_s_own_rows_only() -> None:
    model = tiny_model(cross_video=2)
    model.config.new_token_ids = [12, 13]  # rows Stage II trains: moving them must not move what the comparator reads
    inputs = batch([prompt(2, question=[11, 12, 13, 14])])
    embed = model.get_input_embeddings()
    text = embed(inputs["input_ids"])
    pretrained = model.question_vectors(inputs["input_ids"], text, inputs["attention_mask"], None,
                                        pretrained_only=True)
    kept = [11, 14, *range(20, 22), 30, 31]  # every real, non-tactile token but the new rows
    torch.testing.assert_close(pretrained[0], embed.weight[kept].mean(0))
    _, _, per_sample, compared, _ = model.tactile_features(inputs["input_ids"], videos(2), inputs["attention_mask"],
                                                           None, None)
    with torch.no_grad():
        embed.weight[12:14] += 5.0
    _, _, _, moved, _ = model.tactile_features(inputs["input_ids"], videos(2), inputs["attention_mask"], None, None)
    assert per_sample.tolist() == [2] and torch.equal(compared, moved)
    assert tiny_model().tactile_features(inputs["input_ids"], videos(2), inputs["attention_mask"], None,
                                         None)[3] is None  # nothing reads it without the cross-video layer


def _namings(n: int, k: int, gen: torch.Generator, names: int = 6, tokens: int = 2, hidden: int = 8,
             question_dim: int = 6) -> tuple[list[torch.Tensor], list[torch.Tensor], torch.Tensor, torch.Tensor]:
    """Prompts of k videos of k different named objects (each name: a feature prototype and a name vector), listing
    the names as options in random order; the gold option of each video; and the names' vectors."""
    proto = torch.randn(names, tokens, hidden, generator=torch.Generator().manual_seed(1))
    vectors = torch.randn(names, question_dim, generator=torch.Generator().manual_seed(2))
    feats, options, gold = [], [], []
    for _ in range(n):
        chosen = torch.randperm(names, generator=gen)[:k]
        order = torch.randperm(k, generator=gen)  # option o names object chosen[order[o]]
        feats.append(proto[chosen] + torch.randn(k, tokens, hidden, generator=gen) * 0.3)
        options.append(vectors[chosen[order]])
        gold.append(torch.argsort(order))  # video v's object sits at option argsort(order)[v]
    return feats, options, torch.stack(gold), vectors


def test_name_matcher_assigns_unseen_prompts_and_replaces_the_pick_there_only() -> None:
    from tacreasoner.model.heads import CrossVideoFusion

    fusion = CrossVideoFusion(8, 2, 2.0, 3, 6, tokens_per_video=2, attributes=2).eval()
    gen = torch.Generator().manual_seed(0)
    feats, options, gold, _ = _namings(120, 3, gen)
    fitted = fusion.fit_names(feats, options, gold)
    assert fitted["named"] == 120 and fitted["assigned"] > 0.9
    assert fusion.names_fitted.tolist() == [False, False, False, True]  # fitted for three videos only
    assert not any(p.requires_grad for p in fusion.names.parameters()) and fusion.assignments.requires_grad
    test_feats, test_options, test_gold, _ = _namings(60, 3, gen)
    perms = fusion._permutations[3]
    chosen = fusion._match(torch.stack([f.flatten(1) for f in test_feats]), torch.stack(test_options))
    right = [list(perms[int(c)]) == g.tolist() for c, g in zip(chosen, test_gold, strict=True)]
    assert sum(right) / len(right) > 0.9
    # through forward: a prompt listing three options gets its assignment's verdict in every token; one listing
    # none gets the comparator's pick (directions at zero: the mean of the place verdicts), and so does a
    # two-video prompt listing two options (the matcher was never fitted on two)
    torch.nn.init.normal_(fusion.verdict)
    pair_feats, pair_options, _, _ = _namings(1, 2, gen)
    tokens = torch.cat([test_feats[0], test_feats[0], pair_feats[0]])
    listed = torch.zeros(3, 3, 6)
    listed[0], listed[2, :2] = test_options[0], pair_options[0]
    with torch.no_grad():
        per_sample = torch.tensor([3, 3, 2])
        places = fusion.places(tokens, per_sample, (listed, torch.tensor([3, 0, 2])))
        out, _ = fusion(tokens, per_sample, torch.zeros(3, 6), places=places)
    delta = out - tokens
    assigned = sum(fusion.assignments[v, o] for v, o in enumerate(perms[int(chosen[0])]))
    torch.testing.assert_close(delta[:3], assigned.expand(3, 2, 8))
    torch.testing.assert_close(delta[3:6], fusion.verdict[:3].mean(0).expand(3, 2, 8))
    torch.testing.assert_close(delta[6:], fusion.verdict[:2].mean(0).expand(2, 2, 8))
    with pytest.raises(ValueError, match="as many options as videos"):
        fusion.fit_names(feats[:1], [options[0][:2]], gold[:1])


def test_each_matched_option_s_name_carries_the_mark_of_its_video() -> None:
    from tacreasoner.model.heads import CrossVideoFusion, ReadoutHeads

    heads = ReadoutHeads(CrossVideoFusion(8, 4, 4.0, 3, 6, 2, 2), None, torch.nn.Parameter(torch.zeros(3, 16)))
    fusion = heads.cross_video
    feats, options, gold, _ = _namings(120, 3, torch.Generator().manual_seed(0))
    fusion.fit_names(feats, options, gold)
    torch.nn.init.normal_(heads.option_marks)
    # prompt 0: three videos, its option names at tokens 1-2 (A), 3 (B), 4 (C); prompt 1: one video, no options
    option = torch.tensor([[-1, 0, 0, 1, 2, -1], [-1, -1, -1, -1, -1, -1]])
    listed = torch.zeros(2, 3, 6)
    listed[0] = options[0]
    features = torch.cat([feats[0], feats[1][:1]])
    embeds = torch.zeros(2, 6, 16)
    with torch.no_grad():
        _, _, places = heads.write(features, torch.tensor([3, 1]), torch.zeros(2, 6), (listed, torch.tensor([3, 0])))
        out = heads.mark(embeds, option, places)
    place = gold[0].argsort()  # the video of each option (the matcher gets this training prompt right)
    expected = torch.zeros(2, 6, 16)
    for token, k in ((1, 0), (2, 0), (3, 1), (4, 2)):
        expected[0, token] = heads.option_marks[place[k]]
    torch.testing.assert_close(out, expected)
    assert heads.mark(embeds, option, None) is embeds  # no matcher verdict: the text is left alone


def test_a_model_without_heads_passes_through_the_hook_unchanged() -> None:
    from tacreasoner.model.heads import ReadoutHeads

    model = tiny_model()
    heads = model.projector.heads
    assert isinstance(heads, ReadoutHeads) and heads.cross_video is heads.clip_reader is heads.option_marks is None
    features = torch.randn(3, 2, 8)
    written, loss, places = heads.write(features, torch.tensor([1, 2]), winner=torch.tensor([0, 1]))
    assert written is features and loss is None and places is None
    assert not any(n.startswith(("projector.cross_video", "projector.clip_reader", "projector.option_marks"))
                   for n, _ in model.named_parameters())


def test_option_vectors_average_each_listed_name_over_the_llm_s_own_rows() -> None:
    model = tiny_model(cross_video=3)
    model.config.new_token_ids = [14]
    inputs = batch([prompt(3, question=[11, 12, 13, 14, 15]), prompt(3)])
    mask = torch.zeros_like(inputs["input_ids"])
    mask[0, :5] = torch.tensor([1, 2, 2, 3, 4])  # option A: 12 13, B: 14 (a new row: nothing), C: 15
    mask[1, :3] = 1
    embed = model.get_input_embeddings()
    vectors, counts = model.option_vectors(inputs["input_ids"], embed(inputs["input_ids"]), mask)
    assert counts.tolist() == [3, 0] and vectors.shape == (2, 3, TEXT_HIDDEN)
    torch.testing.assert_close(vectors[0, 0], embed.weight[[12, 13]].mean(0))
    assert not vectors[0, 1].any() and not vectors[1].any()
    torch.testing.assert_close(vectors[0, 2], embed.weight[15])
    # the question vector counts option names as question tokens, once each
    question = model.question_vectors(inputs["input_ids"], embed(inputs["input_ids"]), None, mask)
    torch.testing.assert_close(question[0], embed.weight[[11, 12, 13, 14, 15]].mean(0))


def test_cross_video_verdict_reaches_every_token_of_the_prompt() -> None:
    model = tiny_model(cross_video=2)
    torch.nn.init.normal_(model.projector.cross_video.verdict)
    torch.nn.init.normal_(model.projector.cross_video.directions)
    inputs = batch([prompt(2)])
    places = (inputs["input_ids"][0] == TACTILE_ID).nonzero().flatten()
    pv = videos(2)
    with torch.no_grad():
        before = model.embed_inputs(inputs["input_ids"], pv, inputs["attention_mask"])[0, places]
        model.projector.cross_video.verdict[1] += 1.0  # what "the second video is picked" adds
        after = model.embed_inputs(inputs["input_ids"], pv, inputs["attention_mask"])[0, places]
    assert (after - before).abs().sum(-1).gt(0).all()  # the tokens of both videos carry it


def test_save_then_load_gives_identical_logits(tmp_path) -> None:
    model = tiny_model(sensor_embedding=True, video_slots=2, cross_video=2, clip_reader=True)
    _train_fusion_a_little(model)
    tpv, hidden = ENCODER["tokens_per_video"], model.encoder_config.hidden_size
    labels = torch.full((30, 8), -1)
    labels[:, 0] = torch.arange(30) % 3  # a hardness level per clip: the reader is fitted, and writes its vectors
    model.projector.clip_reader.fit(torch.randn(30, tpv, hidden), labels)
    torch.nn.init.normal_(model.projector.cross_video.out.weight, std=0.2)
    torch.nn.init.normal_(model.projector.cross_video.directions, std=0.2)
    torch.nn.init.normal_(model.projector.cross_video.verdict, std=0.2)
    torch.nn.init.normal_(model.projector.cross_video.feature_mean, std=0.2)  # a saved buffer too
    torch.nn.init.normal_(model.projector.video_slot.shift)
    torch.nn.init.normal_(model.projector.video_slot.mix, std=0.1)
    model.save_pretrained(tmp_path)
    loaded = TacReasonerForCausalLM.from_pretrained(tmp_path).eval()
    inputs = batch([prompt(2), prompt(1)])
    pv = videos(3)
    with torch.no_grad():
        # equal up to kernel rounding (1e-7 on some CPUs: the same sums in another order)
        assert torch.allclose(model(**inputs, pixel_values=pv).logits, loaded(**inputs, pixel_values=pv).logits,
                              rtol=0, atol=1e-5)
    assert loaded.projector.clip_reader.fitted
    assert torch.equal(loaded.projector.clip_reader.readout_weight, model.projector.clip_reader.readout_weight)
    assert loaded.config.encoder == model.config.encoder


def test_generate_returns_only_new_tokens_and_uses_the_tactile_prompt() -> None:
    model = tiny_model()
    inputs = batch([prompt(1)])
    out = model.generate(**inputs, pixel_values=videos(1), max_new_tokens=4, do_sample=False, pad_token_id=0)
    assert out.shape == (1, 4)
    with torch.no_grad():
        first = model(**inputs, pixel_values=videos(1)).logits[0, -1].argmax()
    assert int(out[0, 0]) == int(first)
    with pytest.raises(ValueError, match="placeholder"):
        model.generate(**inputs, pixel_values=videos(2), max_new_tokens=2)


def test_forward_warns_of_nothing_and_its_cache_continues_the_sequence() -> None:
    model = tiny_model().eval()
    inputs = batch([prompt(1)])
    with torch.no_grad(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = model(**inputs, pixel_values=videos(1), use_cache=True)
        assert not [str(w.message) for w in caught if issubclass(w.category, (FutureWarning, DeprecationWarning))]
        following = out.logits[:, -1:].argmax(-1)
        mask = torch.cat([inputs["attention_mask"], torch.ones_like(following)], dim=1)
        step = model(input_ids=following, attention_mask=mask, past_key_values=out.past_key_values)
        embeds = model.embed_inputs(inputs["input_ids"], videos(1), inputs["attention_mask"])
        embeds = torch.cat([embeds, model.get_input_embeddings()(following)], dim=1)
        whole = model(inputs_embeds=embeds, attention_mask=mask)
    assert torch.allclose(step.logits[0, -1], whole.logits[0, -1], atol=1e-5)


def test_wraps_a_causal_lm_saved_to_disk_without_changing_its_text_path(tmp_path) -> None:
    """The code path a real Qwen2.5 checkpoint takes, with a tiny Qwen2 saved to disk."""
    from transformers import Qwen2Config, Qwen2ForCausalLM

    torch.manual_seed(0)
    llm = Qwen2ForCausalLM(Qwen2Config(hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                                       num_key_value_heads=2, intermediate_size=128, vocab_size=280)).eval()
    llm.save_pretrained(tmp_path / "llm")
    model = TacReasonerForCausalLM.from_llm(tmp_path / "llm", tactile_token_id=TACTILE_ID, vocab_size=300,
                                             new_token_ids=list(range(280, 300)), encoder=ENCODER).eval()
    assert model.get_input_embeddings().num_embeddings == 300
    text = torch.tensor([[5, 6, 7, 8]])
    with torch.no_grad():
        assert torch.allclose(model(input_ids=text).logits[..., :280], llm(input_ids=text).logits, atol=1e-5)
    assert model.config.new_token_ids == list(range(280, 300))


def test_auto_classes_know_tacreasoner_after_import_tacreasoner_model(tmp_path) -> None:
    tiny_model().save_pretrained(tmp_path)
    for order in ("import tacreasoner.model\nfrom transformers import AutoModelForCausalLM, AutoConfig",
                  "from transformers import AutoModelForCausalLM, AutoConfig\nimport tacreasoner.model"):
        code = (f"{order}\nm = AutoModelForCausalLM.from_pretrained({str(tmp_path)!r})\n"
                f"c = AutoConfig.from_pretrained({str(tmp_path)!r})\n"
                "print(type(m).__name__, type(c).__name__)")
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr[-2000:]
        assert done.stdout.split()[-2:] == ["TacReasonerForCausalLM", "TacReasonerConfig"]


def test_importing_tacreasoner_does_not_import_torch() -> None:
    code = ("import sys, tacreasoner, tacreasoner.sim, tacreasoner.cli\n"
            "print('torch' in sys.modules, 'transformers' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.split() == ["False", "False"], done.stderr


def test_cached_appearance_tokens_give_the_same_output_as_running_the_vit() -> None:
    model = tiny_model()
    _train_fusion_a_little(model)
    inputs = batch([prompt(2)])
    pv = videos(2)
    with torch.no_grad():
        cached = model.tactile_encoder.appearance_tokens(pv)
        direct = model(**inputs, pixel_values=pv).logits
        reused = model(**inputs, pixel_values=pv, appearance_tokens=cached).logits
    assert torch.allclose(direct, reused, atol=1e-6)
    with pytest.raises(ValueError, match="appearance tokens must be 2×3×32"):
        model(**inputs, pixel_values=pv, appearance_tokens=cached[:, :1])


def test_set_clip_reader_adds_or_removes_it_and_the_saved_config_follows(tmp_path) -> None:
    from tacreasoner.train.head_settings import MAX_LEVELS, READER_TRAITS

    model = tiny_model()
    assert model.projector.clip_reader is None and not model.encoder_config.clip_reader
    inputs, pv = batch([prompt(1)]), videos(1)
    with torch.no_grad():
        before = model(**inputs, pixel_values=pv).logits
        model.set_clip_reader(READER_TRAITS, MAX_LEVELS)
        assert torch.equal(model(**inputs, pixel_values=pv).logits, before)  # unfitted: nothing changes
    assert model.config.encoder["clip_reader"] and model.projector.clip_reader is not None
    model.save_pretrained(tmp_path)
    assert TacReasonerForCausalLM.from_pretrained(tmp_path).projector.clip_reader is not None
    model.set_clip_reader()
    assert model.projector.clip_reader is None and not model.encoder_config.clip_reader


def test_a_transformers_without_subconfigspec_is_a_clear_error_and_pyproject_asks_for_one_with_it() -> None:
    from tacreasoner.model.configuration import MIN_TRANSFORMERS

    code = ("import transformers.configuration_utils as c; del c.SubConfigSpec; "
            "import tacreasoner.model.configuration")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode != 0
    assert f"tacreasoner needs transformers>={MIN_TRANSFORMERS}" in done.stderr.splitlines()[-1]
    pyproject = (Path(__file__).resolve().parents[2] / "pyproject.toml").read_text()
    assert pyproject.count(f'"transformers>={MIN_TRANSFORMERS}"') == 2 and '"transformers>=5.0"' not in pyproject
