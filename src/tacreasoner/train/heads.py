"""Fit the model's read-out heads when Stage II starts, and give Stage II out-of-fold readings of its examples.

In Stage II the tactile encoder is frozen, so each training prompt's encoder output is fixed: every head
(``model.heads``: clip reader, comparator, name matcher) is fitted on those outputs against the training data's gold
and frozen, and Stage II's LoRA and projector learn to read its verdicts from the tokens. A head read on the prompts
it was fitted on gives near-gold verdicts, which Stage II would learn to trust; so the verdict each training prompt
carries comes from a copy of the head fitted on the other objects (``data.head_folds`` folds,
:func:`tacreasoner.model.heads.crossfit`), and the head kept for inference is fitted on all of them. Only the
benchmark's train split gives labels. Fitting is seeded, so a resumed Stage II fits the same heads again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

from tacreasoner.model.heads import ComparatorHead, HeadRows, NameMatcherHead, ReadoutHead, crossfit
from tacreasoner.train.data import Tokenized, VideoBank, VideoKey, collate, train_items, video_key
from tacreasoner.train.reader import clip_labels

__all__ = ["encoder_outputs", "fit_heads", "fit_heads_once", "model_heads", "video_objects"]


def model_heads(model: Any) -> list[ReadoutHead]:
    """The read-out heads ``model`` holds, in the order they are fitted."""
    heads: list[ReadoutHead] = []
    if model.projector.clip_reader is not None:
        heads.append(model.projector.clip_reader)
    fusion = model.projector.cross_video
    if fusion is not None:
        heads.append(ComparatorHead(fusion))
        if model.encoder_config.cross_video_names:
            heads.append(NameMatcherHead(fusion))
    return heads


def video_objects(bench: str | Path) -> dict[str, str]:
    """Each train video's path → the object it was recorded on (the unit of the cross-fitting folds)."""
    root, items = train_items(Path(bench))
    out: dict[str, str] = {}
    for item in items:
        for i, ref in enumerate(item.videos):
            objects = item.objects or []
            obj = objects[i] if len(objects) == len(item.videos) else (objects[0] if objects else "")
            if obj:
                out[video_key(ref, root, f"item {item.id!r}")[0]] = obj
    return out


def _targets(head: ReadoutHead, model: Any, examples: Sequence[Tokenized], labels: dict[VideoKey, list[int]] | None
             ) -> list[Any]:
    if head.name == "clip_reader":
        blank = [-1] * len(model.projector.clip_reader.traits)
        return [torch.tensor([(labels or {}).get(k, blank) for k in e.videos], dtype=torch.long) for e in examples]
    if head.name == "comparator":
        index = {a: i for i, a in enumerate(model.encoder_config.cross_video_attributes)}
        return [(e.winner, index.get(e.attribute, -100), e.more) if e.winner >= 0 and len(e.videos) >= 2 else None
                for e in examples]
    if head.name == "name_matcher":
        return [tuple(e.assignment) if e.assignment else None for e in examples]
    raise ValueError(f"no training targets known for the read-out head {head.name!r}")


def fit_heads(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank, bench: str | Path,
              seed: int, folds: int = 5, progress: Callable[[int, int], None] | None = None, batch_size: int = 16,
              ) -> tuple[list[Tokenized], dict[str, Any]]:
    """Fit every read-out head of ``model`` on ``examples`` and freeze it; return the examples, each carrying its
    out-of-fold readings (in-sample ones when ``folds`` < 2), and per head what it was fitted on and how well it
    reads its own fit and the held-out folds."""
    heads = model_heads(model)
    if not heads:
        return list(examples), {}
    was_training = model.training
    model.eval()
    videos, questions, options = encoder_outputs(model, processor, examples, bank, batch_size, progress)
    model.train(was_training)
    fusion = model.projector.cross_video
    rows = HeadRows(videos=videos, questions=torch.cat(questions) if fusion is not None and questions else None,
                    options=options if fusion is not None and options else None)
    labels = clip_labels(bench) if model.projector.clip_reader is not None else None
    where = video_objects(bench)
    objects = [[where.get(k[0], k[0]) for k in e.videos] for e in examples]
    readings: list[dict[str, torch.Tensor]] = [{} for _ in examples]
    stats: dict[str, Any] = {}
    for head in heads:
        rows.targets = _targets(head, model, examples, labels)
        if not any(t is not None and (not torch.is_tensor(t) or bool((t >= 0).any())) for t in rows.targets):
            stats[head.name] = {"fitted_on": 0}
            continue
        if folds >= 2:
            cross = crossfit(head, rows, objects, folds, seed)
            read = [r if r is not None else head.silent(rows, i) for i, r in enumerate(cross.readings)]
            out_of_fold = {"folds": cross.folds, "held_out_agreement": _agreement(head, read, rows.targets)}
        else:
            read, out_of_fold = None, {"folds": "none (in-sample readings: data.head_folds < 2)"}
        stats[head.name] = {**head.fit_rows(rows, seed=seed), **out_of_fold}
        if read is None:
            read = head.read_rows(rows)
        for i, r in enumerate(read):
            readings[i][head.reading] = r
    if fusion is not None and stats.get("name_matcher", {}).get("named"):
        model.projector.heads.start_marks(model.get_input_embeddings().weight, seed + 2)
    _freeze_fitted(model)
    out = [dataclasses.replace(e, readings=r) for e, r in zip(examples, readings, strict=True)]
    return out, stats


def fit_heads_once(accelerator: Any, model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank,
                   bench: str | Path, seed: int, folds: int = 5, progress: Callable[[int, int], None] | None = None,
                   ) -> tuple[list[Tokenized], dict[str, Any]]:
    """:func:`fit_heads` on the main process only; the other processes receive the fitted projector (heads, option
    marks), the examples' readings and the statistics instead of running the frozen encoder over every training
    prompt and fitting the same heads again."""
    if accelerator.num_processes == 1:
        return fit_heads(model, processor, examples, bank, bench, seed, folds, progress)
    from accelerate.utils import broadcast_object_list

    payload: list[Any] = [None]
    if accelerator.is_main_process:
        out, stats = fit_heads(model, processor, examples, bank, bench, seed, folds, progress)
        state = {k: v.detach().cpu() for k, v in model.projector.state_dict().items()}
        payload = [([e.readings for e in out], stats, state)]
    broadcast_object_list(payload, from_process=0)
    readings, stats, state = payload[0]
    if accelerator.is_main_process:
        return out, stats
    model.projector.load_state_dict(state)
    _freeze_fitted(model)
    return [dataclasses.replace(e, readings=r) for e, r in zip(examples, readings, strict=True)], stats


def _freeze_fitted(model: Any) -> None:
    """The comparator's fitted parts stay as fitted through Stage II."""
    fusion = model.projector.cross_video
    if fusion is not None:
        for p in fusion.comparator_parameters:
            p.requires_grad_(False)


def _agreement(head: ReadoutHead, read: list[torch.Tensor], targets: list[Any]) -> float | None:
    """The share of targeted prompts (videos, for the clip reader) whose out-of-fold reading is the gold."""
    right = total = 0
    for r, t in zip(read, targets, strict=True):
        if t is None:
            continue
        if head.name == "clip_reader":
            known = t >= 0
            right, total = right + int((r[known] == t[known]).sum()), total + int(known.sum())
        elif head.name == "comparator":
            right, total = right + int(len(r) > 0 and int(r.argmax()) == t[0]), total + 1
        else:
            k = len(t)
            gold = torch.tensor(t).argsort()  # the place of each option
            right, total = right + int(len(r) >= k and torch.equal(r[:k], gold)), total + 1
    return right / total if total else None


def encoder_outputs(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank, batch_size: int = 16,
                    progress: Callable[[int, int], None] | None = None,
                    ) -> tuple[list[torch.Tensor], list[torch.Tensor], list[torch.Tensor]]:
    """Per example the frozen encoder's output for its videos (k×N×H), and with a cross-video layer per batch its
    question vectors and per example its options' name vectors (what the heads read)."""
    videos: list[torch.Tensor] = []
    questions: list[torch.Tensor] = []
    options: list[torch.Tensor] = []
    with torch.no_grad():
        for start in range(0, len(examples), batch_size):
            chunk = examples[start:start + batch_size]
            batch = collate(processor, chunk, bank)
            _, features, per_sample, question, listed = model.tactile_features(
                batch["input_ids"], batch["pixel_values"], batch["attention_mask"], batch["question_mask"],
                batch["sensor_ids"], batch.get("appearance_tokens"))
            videos.extend(features.float().split(per_sample.tolist()))
            if question is not None:
                questions.append(question.float())
            if listed is not None:
                options.extend(vectors[:count].float() for vectors, count in zip(*listed, strict=True))
            if progress is not None:
                progress(min(start + batch_size, len(examples)), len(examples))
    return videos, questions, options
