"""How much a still clip (every frame the first) changes a trained model's tactile encoder output, on real clips.

    PYTHONPATH=src python experiments/2026-11-29_sensor_temporal_diag/still_effect.py MODEL [MODEL ...]

Prints, per model, the relative change ‖f(clip) − f(still)‖ / ‖f(clip)‖ over 16 val clips of runs/sens/bench, and
the same for the temporal branch's own output. Criterion 1 of criteria.md: > 1% on the encoder's output.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import torch

from tacreasoner.evaluate.predict import load_trained


def clips(bench: Path, n: int = 16) -> list[Path]:
    seen: list[Path] = []
    for line in (bench / "val.jsonl").read_text().splitlines():
        for v in json.loads(line)["videos"]:
            path = Path(v["path"])
            if path not in seen:
                seen.append(path)
        if len(seen) >= n:
            break
    return seen[:n]


def main() -> None:
    bench = Path("runs/sens/bench")
    root = Path(json.loads((bench / "bench.json").read_text())["video_root"])
    for model_dir in sys.argv[1:]:
        model, processor = load_trained(model_dir)
        enc = model.tactile_encoder
        x = processor.preprocess_videos([str(root / p) for p in clips(bench)])["pixel_values"]
        still = x[:, :1].expand_as(x).contiguous()
        q = torch.zeros(len(x), model.config.text_config.hidden_size)
        with torch.no_grad():
            appearance = enc.appearance_tokens(x)  # the same appearance for both: only the motion is taken away
            a, b = enc(x, q, appearance=appearance), enc(still, q, appearance=appearance)
            ta, tb = enc.temporal(x, q), enc.temporal(still, q)
        print(f"{model_dir}: encoder {float((a - b).norm() / a.norm()):.2e}, "
              f"temporal branch {float((ta - tb).norm() / ta.norm()):.2e}")


if __name__ == "__main__":
    main()
