"""Shared fixtures: one small simulated dataset per test session (rendering is the slow part), free ports."""

from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path

import pytest

from tacreasoner.sim.generate import generate_dataset


@pytest.fixture(scope="session")
def small_sim_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """14 objects (10 fruit, so real and fake in every split) × 2 repeats × Mini and DIGIT."""
    root = tmp_path_factory.mktemp("small_sim")
    generate_dataset(root, n_objects=14, repeats=2, sensors=["mini", "digit"], seed=3, workers=2)
    return root


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def free_port() -> Callable[[], int]:
    """A TCP port nobody listens on now, per call: a rendezvous address for a launched process group."""
    return _free_port
