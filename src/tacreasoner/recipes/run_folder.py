"""The run folder every recipe trains from: where its benchmark, appearance encoder, LLM, clip cache and each
seed's training live, and the training config of one seed pointed at them (the quickstart's and the PhysiCLeAR
recipe's folders add their own parts)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["RunFolder"]


@dataclass(frozen=True)
class RunFolder:
    """``llm_dir``: an LLM folder given by the user instead of the one fetched into the run folder."""

    root: Path
    llm_dir: Path | None = None

    @property
    def llm(self) -> Path:
        return self.llm_dir or self.root / "llm"

    @property
    def bench(self) -> Path:
        return self.root / "bench"

    @property
    def encoder(self) -> Path:
        return self.root / "encoder"

    @property
    def video_cache(self) -> Path:
        return self.root / "video_cache"

    def train(self, seed: int) -> Path:
        return self.root / "train" / f"seed{seed}"

    def train_config(self, seed: int, config: str | Path, overrides: dict[str, Any] | None = None) -> Any:
        """The training config of one seed (``config``: a shipped config's name or a YAML file) pointed at this
        folder's parts; ``overrides`` (dotted keys) win over both."""
        from tacreasoner.train.config import load_train_config

        return load_train_config(config, {
            "output_dir": str(self.train(seed)), "seed": seed, "model.llm": str(self.llm),
            "model.appearance": str(self.encoder), "data.bench": str(self.bench),
            "data.video_cache": str(self.video_cache), **(overrides or {})})
