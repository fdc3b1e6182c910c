"""Shared fixtures: one small simulated dataset per test session (rendering is the slow part)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.sim.generate import generate_dataset


@pytest.fixture(scope="session")
def small_sim_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """14 objects (10 fruit, so real and fake in every split) × 2 repeats × Mini and DIGIT."""
    root = tmp_path_factory.mktemp("small_sim")
    generate_dataset(root, n_objects=14, repeats=2, sensors=["mini", "digit"], seed=3, workers=2)
    return root
