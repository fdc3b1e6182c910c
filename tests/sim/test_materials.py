"""Catalogue and label derivation."""

from __future__ import annotations

import dataclasses

import pytest

from tacreasoner.sim.materials import (
    FRUITS,
    Material,
    build_object_set,
    catalogue,
    derive_labels,
    get_material,
)
from tacreasoner.sim.sensors import get_sensor


def test_catalogue_has_five_fruit_pairs_and_five_everyday_categories() -> None:
    names = {m.name for m in catalogue()}
    for fruit in FRUITS:
        assert {f"{fruit}_real", f"{fruit}_fake"} <= names
        real, fake = get_material(f"{fruit}_real"), get_material(f"{fruit}_fake")
        assert real.shape == fake.shape and real.radius_mm == fake.radius_mm
        assert derive_labels(real)["real"] is True and derive_labels(fake)["real"] is False
    assert {"sponge", "rubber", "fabric", "wood", "metal"} <= names


def test_labels_follow_the_physics() -> None:
    assert derive_labels(get_material("sponge"))["vtv150k"]["hardness"] == 0
    assert derive_labels(get_material("metal"))["vtv150k"]["hardness"] == 2
    assert derive_labels(get_material("metal"))["vtv150k"]["friction"] == 0
    assert derive_labels(get_material("rubber"))["vtv150k"]["friction"] == 2
    assert derive_labels(get_material("strawberry_real"))["vtv150k"]["protrusion"] == 2
    assert derive_labels(get_material("sponge"))["vtv150k"]["elasticity"] == 2
    assert derive_labels(get_material("metal"))["vtv150k"]["elasticity"] == 0
    assert derive_labels(get_material("fabric"))["physiclear"]["roughness"] == 2
    assert derive_labels(get_material("metal"))["physiclear"]["roughness"] == 0
    assert derive_labels(get_material("sponge"))["real"] is None


def test_procedural_objects_cover_every_label_level() -> None:
    objects = build_object_set(300, seed=0)
    assert len({m.name for m in objects}) == 300
    for vocab, attrs in (("vtv150k", ("hardness", "protrusion", "elasticity", "friction")),
                         ("physiclear", ("hardness", "roughness", "bumpiness"))):
        for attr in attrs:
            levels = [derive_labels(m)[vocab][attr] for m in objects]
            counts = [levels.count(k) for k in range(3)]
            assert min(counts) >= 15, (vocab, attr, counts)


def test_object_set_is_deterministic() -> None:
    assert build_object_set(40, seed=3) == build_object_set(40, seed=3)
    assert build_object_set(40, seed=3) != build_object_set(40, seed=4)


def test_material_round_trips_and_rejects_unknown_fields() -> None:
    m = get_material("peach_fake")
    assert Material.from_dict(m.to_dict()) == m
    with pytest.raises(ValueError, match="unknown material fields"):
        Material.from_dict(m.to_dict() | {"colour": "red"})
    with pytest.raises(ValueError, match="mu_k <= mu_s"):
        dataclasses.replace(m, mu_s=0.1, mu_k=0.5)


def test_sensor_specs() -> None:
    assert get_sensor("mini").shape == (240, 320)
    assert get_sensor("digit").shape == (320, 240)
    assert get_sensor("digit@60").fps == 60
    assert get_sensor("mini+markers").markers == (7, 9)
    calibrated = get_sensor("mini+physiclear@10")
    assert calibrated.name == "mini+physiclear@10" and calibrated.fps == 10
    assert calibrated.shading_gain < get_sensor("mini").shading_gain
    assert calibrated.background_rgb == get_sensor("mini").background_rgb
    assert get_sensor("mini+markers+physiclear").markers == (7, 9)
    for bad in ("gelsight9000", "mini@fast", "mini@0", "tac3d+markers", "mini+glitter", "digit+physiclear",
                "mini+physiclear+physiclear"):
        with pytest.raises(ValueError):
            get_sensor(bad)
