"""Answer a benchmark split with a trained model: batched greedy generation, written as it goes, resumable.

The output is the prediction JSONL that ``tacreasoner score`` and :func:`tacreasoner.evaluate.report.evaluate`
read (``{"id", "prediction"}`` per line). Videos are preprocessed exactly as in training
(:class:`tacreasoner.train.data.VideoBank`: uniform frames, segment background from the whole clip).
An interrupted run appends to the same file and skips the items already answered.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

from tacreasoner.tasks.schema import QAItem

__all__ = ["load_trained", "predict_items"]


def load_trained(model_dir: str | os.PathLike[str], adapter: str | os.PathLike[str] | None = None,
                 device: str | None = None) -> tuple[Any, Any]:
    """A saved model + processor (``train`` output ``stage*/model``), optionally with a Stage II adapter on top."""
    from tacreasoner.model.build import load_model
    from tacreasoner.model.stages import load_adapter

    model, processor = load_model(model_dir)
    if adapter is not None:
        model = load_adapter(model, adapter)
    device = device or ("cuda" if torch.cuda.is_available() else "cpu")
    return model.to(device).eval(), processor


def _done_ids(path: Path) -> set[str]:
    if not path.is_file():
        return set()
    done = set()
    with path.open(encoding="utf-8") as f:
        for line in f:
            try:
                done.add(json.loads(line)["id"])
            except (json.JSONDecodeError, KeyError):
                continue  # a line cut by a crash: the item is answered again
    return done


@torch.no_grad()
def predict_items(model: Any, processor: Any, items: Sequence[QAItem], video_root: str | os.PathLike[str],
                  out_path: str | os.PathLike[str], *, batch_size: int = 32, max_new_tokens: int = 256,
                  progress: Callable[[int, int], None] | None = None,
                  video_cache: str | os.PathLike[str] | None = None) -> Path:
    """Greedy answers for ``items`` appended to ``out_path`` (items already there are skipped).

    ``video_cache``: the training run's preprocessed-video directory, reused when given."""
    from tacreasoner.train.data import VideoBank, video_key

    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.is_file() and out.read_bytes()[-1:] not in (b"", b"\n"):
        with out.open("a", encoding="utf-8") as f:  # a crash cut the last line: close it so appends stay valid
            f.write("\n")
    done = _done_ids(out)
    todo = [item for item in items if item.id not in done]
    root = Path(video_root)
    keys = {item.id: [video_key(v, root, f"item {item.id!r}") for v in item.videos] for item in todo}
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for ks in keys.values() for k in ks], cache_dir=video_cache)
    base = getattr(model, "get_base_model", lambda: model)()
    device = next(base.parameters()).device
    if progress is not None:
        progress(len(items) - len(todo), len(items))
    # similar lengths together: less padding in each generate call
    todo.sort(key=lambda item: (len(item.videos), len(item.question)))
    eos, pad = processor.eos_token_ids, processor.tokenizer.pad_token_id
    with out.open("a", encoding="utf-8") as f:
        for start in range(0, len(todo), batch_size):
            chunk = todo[start:start + batch_size]
            rows = []
            for item in chunk:
                enc = processor.encode_conversation(processor.messages(item.question), add_generation_prompt=True)
                rows.append({"input_ids": enc.input_ids, "question_mask": enc.question_mask,
                             "pixel_values": torch.zeros(0), "sensor_ids": torch.zeros(0, dtype=torch.long)})
            batch = dict(processor.collate(rows, padding_side="left"))
            videos = bank.batch([k for item in chunk for k in keys[item.id]])
            batch.update({k: v for k, v in videos.items() if k != "appearance_tokens"})
            batch = {k: v.to(device) for k, v in batch.items()}
            new = base.generate(**batch, max_new_tokens=max_new_tokens, do_sample=False, eos_token_id=eos,
                                pad_token_id=pad)
            texts = processor.tokenizer.batch_decode(new, skip_special_tokens=True)
            for item, text in zip(chunk, texts, strict=True):
                f.write(json.dumps({"id": item.id, "prediction": text.strip(), "task": item.task}) + "\n")
            f.flush()
            if progress is not None:
                progress(len(items) - len(todo) + start + len(chunk), len(items))
    return out
