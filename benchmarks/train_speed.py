"""Seconds per training step of the quickstart's recipe, before and after the CPU speed-ups, side by side.

Usage (after `tacreasoner quickstart`, whose data, LLM, encoder and Stage I model it trains on):

    python benchmarks/train_speed.py [--run runs/quickstart] [--steps 160]

Absolute times on shared 2-core machines drift by ±25% between runs, so separate runs cannot rank changes of
10%. Instead one Stage I and one Stage II run of the quickstart's settings switch variant at *every step*
(round robin) and each variant's steps are averaged: every variant sees the same mix of batches and the same
machine load. Variants (attention as the quickstart config sets it, sdpa, unless named):

- ``before``: the LM head over every position, ``nn.Dropout`` in LoRA, padded batches (the settings up to
  2026-11-24);
- ``padded``: the LM head on labelled positions only (``loss_only``), ``CpuDropout`` (model/dropout.py), padded
  batches (the settings up to 2026-11-27);
- ``packed``: ``padded`` on packed rows with the shared prompt prefix once (model/packing.py; the default on the
  CPU from 2026-11-28);
- ``packed, eager``: ``packed`` with eager attention; ``packed, full head`` / ``packed, nn.Dropout``: ``packed``
  with one earlier speed-up undone, to show what each is still worth. (Stage I has no LoRA, so no dropout variant.)

The first 5 steps (warm-up) are not counted. Results: benchmarks/results/train_speed.{json,md}.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, quickstart_stage_config, stamp

_BASE = {"attention": "sdpa", "loss_only": True, "cpu_dropout": True, "pack": True}
VARIANTS = {
    "before": {**_BASE, "loss_only": False, "cpu_dropout": False, "pack": False},
    "padded": {**_BASE, "pack": False},
    "packed": _BASE,
    "packed, eager": {**_BASE, "attention": "eager"},
    "packed, full head": {**_BASE, "loss_only": False},
    "packed, nn.Dropout": {**_BASE, "cpu_dropout": False},
}
"""Variant → its settings; the first is the reference of the × column."""
STAGE1_SKIPS = ("packed, nn.Dropout",)
WARMUP = 5


class Switch:
    """Puts the model into one variant between steps; the trainer calls ``on_log`` after every step."""

    def __init__(self, stage: int) -> None:
        from torch import nn

        from tacreasoner.model import modeling, stages
        from tacreasoner.model.dropout import CpuDropout

        self.names = [n for n in VARIANTS if not (stage == 1 and n in STAGE1_SKIPS)]
        self.times: dict[str, list[float]] = {n: [] for n in self.names}
        self.step, self.started, self.model = 0, 0.0, None
        self.loss_only, self.pack = True, True
        self._nn, self._cpu_dropout = nn, CpuDropout
        configure = stages.configure_stage

        def capture(model, *args, **kwargs):
            self.model = model
            return configure(model, *args, **kwargs)

        stages.configure_stage = capture
        forward = modeling.TacReasonerForCausalLM.forward
        switch = self

        def patched(model_self, *args, loss_only: bool = False, pack: bool = False, **kwargs):
            return forward(model_self, *args, loss_only=loss_only and switch.loss_only,
                           pack=pack and loss_only and switch.loss_only and switch.pack, **kwargs)

        modeling.TacReasonerForCausalLM.forward = patched
        self._restore = lambda: (setattr(stages, "configure_stage", configure),
                                 setattr(modeling.TacReasonerForCausalLM, "forward", forward))

    def close(self) -> None:
        """Undo the patches: a second stage's switch must wrap the real forward, not this one (until 2026-11-27
        Stage II ran under Stage I's last variant too, so its rows could not differ in head or packing)."""
        self._restore()

    def set(self, name: str, stage: int) -> None:
        settings = VARIANTS[name]
        self.model.language_model.config._attn_implementation = settings["attention"]
        self.loss_only, self.pack, cpu_dropout = settings["loss_only"], settings["pack"], settings["cpu_dropout"]
        for module in self.model.modules():
            drops = getattr(module, "lora_dropout", None)
            if isinstance(drops, self._nn.ModuleDict):
                for key, drop in drops.items():
                    p = drop.p
                    drops[key] = self._cpu_dropout(p) if cpu_dropout else self._nn.Dropout(p)

    def on_log(self, stage: int):
        def record(rec: dict) -> None:
            now = time.perf_counter()
            current = self.names[self.step % len(self.names)]
            if self.step >= WARMUP:
                self.times[current].append(now - self.started)
            self.step += 1
            self.set(self.names[self.step % len(self.names)], stage)
            self.started = time.perf_counter()

        return record


def run_stage(run: Path, stage: int, steps: int, work: Path) -> dict[str, list[float]]:
    from tacreasoner.train.trainer import train_stage

    config = quickstart_stage_config(run, stage, steps, work / f"stage{stage}_run")
    config.runtime.pack_sequences = True  # the trainer asks for packing; each variant decides
    switch = Switch(stage)  # step 1 runs the trainer's own settings: it is inside the warm-up
    try:
        train_stage(config, stage, on_log=switch.on_log(stage))
    finally:
        switch.close()
    return switch.times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, default=Path("runs/quickstart"), help="A finished quickstart run directory.")
    ap.add_argument("--steps", type=int, default=160, help="Steps per stage (shared round robin by the variants).")
    args = ap.parse_args()
    if not (args.run / "train" / "seed0" / "stage1" / "model").is_dir():
        sys.exit(f"{args.run}: no train/seed0/stage1/model — run `tacreasoner quickstart` first")
    info = stamp()
    results: dict[str, dict] = {}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for stage in (1, 2):
            times = run_stage(args.run, stage, args.steps, Path(tmp))
            base = statistics.mean(times[next(iter(VARIANTS))])
            results[f"stage{stage}"] = {}
            for name, values in times.items():
                mean = statistics.mean(values)
                results[f"stage{stage}"][name] = {"steps": len(values), "mean_s": mean,
                                                  "median_s": statistics.median(values), "vs_before": mean / base}
                rows.append([f"Stage {'I' if stage == 1 else 'II'}", name, len(values), round(mean, 4),
                             round(statistics.median(values), 4), f"{mean / base:.2f}"])
    md = header_md("Training step time of the quickstart's recipe: CPU speed-ups side by side", info)
    md += (f"Run: `{args.run}` (the quickstart's data, LLM, encoder and Stage I model); the quickstart's settings, "
           f"{args.steps} steps per stage with the variant switched at every step (round robin), the first {WARMUP} "
           "not counted. `before`: LM head over every position, `nn.Dropout` in LoRA, padded batches; `padded`: LM "
           "head on the labelled positions only (`loss_only`), `CpuDropout` (model/dropout.py), padded batches (the "
           "quickstart until 2026-11-27); `packed`: `padded` on packed rows with the shared prompt prefix once "
           "(model/packing.py; the CPU default now); the other rows change one thing of `packed`. Attention: sdpa "
           "(the quickstart config's) unless named.\n\n")
    md += md_table(["stage", "variant", "steps", "mean s/step", "median s/step", "× before"], rows)
    publish("train_speed", {**info, "run": str(args.run), "steps_per_stage": args.steps, "stages": results}, md)


if __name__ == "__main__":
    main()
