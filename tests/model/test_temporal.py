"""The temporal branch must carry the clip's motion: with ``temporal_norm`` its difference tokens are scaled to
unit RMS per clip, so small real frame differences (a few grey levels) still move its output, where without it the
output barely depends on the clip (what the shipped quickstart model showed: a still clip changed its encoder's
output by 1e-7, relative)."""

from __future__ import annotations

import torch

from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.temporal import TemporalBranch


def _branch(norm: bool) -> TemporalBranch:
    torch.manual_seed(0)
    config = TactileEncoderConfig(image_size=(32, 32), num_frames=8, temporal_hidden_size=32, hidden_size=16,
                                  temporal_tokens=2, fusion_heads=2, question_conditioning=False, temporal_norm=norm)
    return TemporalBranch(config, question_dim=8).eval()


def _clips(scale: float) -> tuple[torch.Tensor, torch.Tensor]:
    """A clip whose frames change by ``scale`` (normalised pixel units) per step, and the same clip held still."""
    g = torch.Generator().manual_seed(1)
    start = torch.rand(2, 1, 3, 32, 32, generator=g)
    steps = scale * torch.randn(2, 7, 3, 32, 32, generator=g)
    moving = torch.cat([start, start + steps.cumsum(dim=1)], dim=1)
    return moving, start.expand_as(moving).contiguous()


def _motion_effect(branch: TemporalBranch, scale: float) -> float:
    moving, still = _clips(scale)
    with torch.no_grad():
        a, b = branch(moving), branch(still)
    return float((a - b).norm() / a.norm())


def test_normalised_tokens_let_small_differences_move_the_output() -> None:
    plain, normed = _branch(False), _branch(True)
    small = 0.02  # ~1 grey level over ImageNet's std: the size of an imprint's change between two frames
    assert _motion_effect(normed, small) > 10 * _motion_effect(plain, small)
    assert _motion_effect(normed, small) > 0.05


def test_normalised_branch_reads_the_pattern_not_the_contrast() -> None:
    """A sensor that shows the same motion with twice the contrast gives (nearly) the same tokens."""
    normed = _branch(True)
    moving, _ = _clips(0.02)
    first = moving[:, :1]
    brighter = first + 2.0 * (moving - first)  # every change twice as large
    with torch.no_grad():
        a, b = normed(moving), normed(brighter)
    assert float((a - b).norm() / a.norm()) < 0.1


def test_a_still_clip_stays_finite_and_the_default_is_off() -> None:
    _, still = _clips(0.02)
    with torch.no_grad():
        out = _branch(True)(still)
    assert torch.isfinite(out).all()
    assert TactileEncoderConfig().temporal_norm is False  # models saved before the option answer as they did
