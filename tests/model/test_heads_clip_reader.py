"""The clip reader: a closed-form read-out of a clip's traits whose level vectors are added to its tokens."""

from __future__ import annotations

import pytest
import torch

from tacreasoner.model.heads import ClipReader
from tacreasoner.model.tactile_encoder import TactileProjector
from tacreasoner.train.head_settings import MAX_LEVELS, READER_TRAITS

HARDNESS, REAL, STATE = (READER_TRAITS.index(t) for t in ("hardness", "real", "state"))


def _clips(n: int = 120, tokens: int = 2, hidden: int = 8, seed: int = 0) -> tuple[torch.Tensor, torch.Tensor]:
    """Videos whose first three features say the hardness level (one each) and fourth whether real; other traits
    unknown."""
    g = torch.Generator().manual_seed(seed)
    hardness, real = torch.randint(0, 3, (n,), generator=g), torch.randint(0, 2, (n,), generator=g)
    videos = torch.randn(n, tokens, hidden, generator=g) * 0.1
    videos[:, 0, :3] += torch.nn.functional.one_hot(hardness, 3).float() * 2
    videos[:, 0, 3] += real.float() * 2
    labels = torch.full((n, len(READER_TRAITS)), -1, dtype=torch.long)
    labels[:, HARDNESS], labels[:, REAL] = hardness, real
    labels[n // 2:, REAL] = -1  # only half the clips are fruit
    return videos, labels


def test_an_unfitted_reader_leaves_tokens_unchanged() -> None:
    reader = ClipReader(hidden=8, tokens_per_video=2, traits=READER_TRAITS, levels=MAX_LEVELS)
    videos, _ = _clips()
    assert not reader.fitted
    assert torch.equal(reader(videos), videos)


def test_fit_reads_each_labelled_trait_and_writes_one_loud_vector_per_level() -> None:
    reader = ClipReader(hidden=8, tokens_per_video=2, traits=READER_TRAITS, levels=MAX_LEVELS)
    videos, labels = _clips()
    out = reader.fit(videos, labels, penalty=1.0, seed=3)
    assert set(out) == {"hardness", "real"}
    assert out["hardness"] == {"videos": 120, "read": 1.0} and out["real"] == {"videos": 60, "read": 1.0}
    assert reader.known[HARDNESS].tolist() == [True, True, True] + [False] * (MAX_LEVELS - 3)
    assert not bool(reader.known[STATE].any())
    test, test_labels = _clips(seed=1)
    levels = reader.levels(test)
    assert torch.equal(levels[:, HARDNESS], test_labels[:, HARDNESS])
    assert bool((levels[:, STATE] == -1).all())
    # each video gets the sum of its levels' vectors, on every token
    added = reader(test) - test
    want = reader.readings[HARDNESS, levels[:, HARDNESS]] + reader.readings[REAL, levels[:, REAL]]
    assert torch.allclose(added, want.unsqueeze(1).expand_as(added), atol=1e-5)
    token_norm = videos.reshape(-1, 8).pow(2).sum(-1).mean().sqrt()
    assert 0.3 < float(reader.readings[HARDNESS].detach().norm(dim=-1).mean() / token_norm) < 3.0


def test_fit_refuses_what_it_cannot_use() -> None:
    reader = ClipReader(hidden=8, tokens_per_video=2, traits=READER_TRAITS, levels=MAX_LEVELS)
    videos, labels = _clips()
    with pytest.raises(ValueError, match="V×8 labels"):
        reader.fit(videos, labels[:, :3])
    one_level = torch.full_like(labels, -1)
    one_level[:, HARDNESS] = 1
    with pytest.raises(ValueError, match="two levels or more"):
        reader.fit(videos, one_level)
    labels[0, STATE] = MAX_LEVELS
    with pytest.raises(ValueError, match="past the reader"):
        reader.fit(videos, labels)


def test_the_projector_reads_each_video_before_the_cross_video_layer() -> None:
    from tacreasoner.model.heads import CrossVideoFusion, HeadModules

    projector = TactileProjector(8, 16, heads=HeadModules(CrossVideoFusion(8, 4, 4.0, 3, 8, 2, 1),
                                                          ClipReader(8, 2, READER_TRAITS, MAX_LEVELS)))
    videos, labels = _clips(n=6)

    def project() -> torch.Tensor:
        features, _, _ = projector.heads.write(videos, torch.tensor([1, 2, 3]), torch.zeros(3, 8))
        return projector(features)

    before = project()
    projector.clip_reader.fit(*_clips(), penalty=1.0)
    after = project()
    assert not torch.allclose(before, after)
    assert projector.clip_reader.levels(videos)[:, HARDNESS].tolist() == labels[:, HARDNESS].tolist()
