"""Sensor styles: the ``+varied`` option gives each clip its own look and leaves the contact alone."""

from __future__ import annotations

import numpy as np
import pytest

from tacreasoner.sim.generate import simulate_clip
from tacreasoner.sim.materials import build_object_set
from tacreasoner.sim.sensors import clip_look, get_sensor, vary_look


def test_varied_option_is_named_and_keeps_geometry() -> None:
    plain, varied = get_sensor("mini"), get_sensor("mini+varied")
    assert varied.name == "mini+varied" and varied.varied and not plain.varied
    assert (varied.shape, varied.fps, varied.mm_per_px) == (plain.shape, plain.fps, plain.mm_per_px)
    with pytest.raises(ValueError, match="NAME\\+varied"):
        get_sensor("mini+shiny")


def test_each_draw_is_a_different_look_of_the_same_sensor() -> None:
    style = get_sensor("digit+varied")
    looks = [vary_look(style, np.random.default_rng(k)) for k in range(20)]
    assert len({look.background_rgb for look in looks}) == 20
    assert len({look.lights[0].rgb for look in looks}) > 1  # LED colours change order
    for look in looks:
        assert not look.varied and look.shape == style.shape and look.fps == style.fps
        assert all(20.0 <= v <= 170.0 for v in look.background_rgb)
        assert 0.4 * style.shading_gain <= look.shading_gain <= 2.0 * style.shading_gain


def test_varied_clip_has_the_plain_clips_contact_but_its_own_colours() -> None:
    material = build_object_set(2, 0)[1]
    plain = simulate_clip(material, "mini", "slide", seed=(0, 1, 0, 0))
    varied = simulate_clip(material, "mini+varied", "slide", seed=(0, 1, 0, 0))
    again = simulate_clip(material, "mini+varied", "slide", seed=(0, 1, 0, 0))
    other = simulate_clip(material, "mini+varied", "slide", seed=(0, 1, 1, 0))
    np.testing.assert_array_equal(varied.trajectory.object_shift_mm, plain.trajectory.object_shift_mm)
    np.testing.assert_array_equal(varied.frames, again.frames)  # deterministic per clip seed
    assert np.abs(varied.frames[0].mean((0, 1)) - plain.frames[0].mean((0, 1))).max() > 3.0
    assert np.abs(varied.frames[0].mean((0, 1)) - other.frames[0].mean((0, 1))).max() > 3.0


def test_a_share_of_varied_clips_keeps_the_rest_in_the_sensors_own_look() -> None:
    plain, every, half = get_sensor("mini"), get_sensor("mini+varied"), get_sensor("mini+varied50")
    assert (half.name, half.varied, every.varied) == ("mini+varied50", 0.5, 1.0)
    seeds = [(0, k, r, 0) for k in range(100) for r in range(2)]
    looks = [clip_look(half, seed) for seed in seeds]
    own = [look.background_rgb == plain.background_rgb for look in looks]
    assert 0.4 < sum(own) / len(own) < 0.6
    for seed, look, is_own in zip(seeds, looks, own, strict=True):
        assert not look.varied
        # a varied clip looks as it would with every clip varied: the share picks clips, not looks
        assert look.background_rgb == (plain.background_rgb if is_own else clip_look(every, seed).background_rgb)
    assert clip_look(plain, seeds[0]) is plain
    for bad in ("mini+varied0", "mini+varied100", "mini+varied5x"):
        with pytest.raises(ValueError, match="NAME\\+variedNN"):
            get_sensor(bad)
