"""Answer a benchmark split with a trained model: batched greedy generation, written as it goes, resumable.

The output is the prediction JSONL that ``tacreasoner score`` and :func:`tacreasoner.evaluate.report.evaluate`
read (``{"id", "prediction"}`` per line). Videos are preprocessed exactly as in training
(:class:`tacreasoner.train.data.VideoBank`: uniform frames, segment background from the whole clip).
An interrupted run appends to the same file and skips the items already answered.

``touch`` is the removed-touch control (Touch-R1's check that answers use touch): the same items answered with
their real videos, with a blank clip in place of every video, or with the videos of other items of the split.
A model whose accuracy holds without its own touch answers from the text alone.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from tacreasoner.tasks.schema import QAItem

__all__ = ["ANSWER_DTYPES", "ANSWER_MODES", "TOUCH_MODES", "answer_with_model", "answerer_id", "blank_video",
           "check_answers", "check_dtype", "check_touch", "load_trained", "predict_items", "predict_split",
           "predictions_path", "resolve_dtype", "set_aside_stale", "shuffle_videos", "steps_path"]

ANSWER_MODES = ("direct", "stepwise", "stepwise-vote", "auto")
"""How questions over several objects are answered: one pass (``direct``), or one pass per video and named object
and the conclusion by the rule (``stepwise``: :mod:`tacreasoner.evaluate.stepwise`); ``stepwise-vote`` reads each
video in every single-clip wording and takes the majority level; ``auto``: a question in a wording the model was
trained on in one pass, any other as ``stepwise-vote`` (``stepwise.TRAINED_ONE_PASS_MODES``)."""
TOUCH_MODES = ("real", "blank", "shuffled")
"""What the model gets as touch: the item's own videos, a featureless clip, or other items' videos."""

VideoKey = tuple[str, int | None, int | None]
REPLY_TOKENS = 512
"""Default reply budget: room for the longest TouchCoT reasoning the builder writes (OSC and combined attributes over
three videos: up to ~420 tokens). A reply stopped by the budget has no ``<answer>`` and scores wrong, so a budget
shorter than what the model was trained to write costs accuracy silently; :func:`cut_replies` counts them."""

ANSWER_DTYPES = {"float32": torch.float32, "bfloat16": torch.bfloat16, "auto": None}
"""Weights' type when answering; ``auto`` is bfloat16 where the hardware computes it natively, float32 elsewhere
(emulated bf16 is slower than float32). bf16 replies differ from float32's by rounding: three SmolLM2 quickstart
models on DynTAC-Sim val gave 91-93% identical replies and accuracy within 1.2 points, none significant; answering
took 0.57x the time on a 2-core EPYC with AVX512_BF16 (experiments/2026-11-28_quickstart_b4)."""


def check_dtype(dtype: str | None) -> str | None:
    """``dtype`` if it is a known answering type (None: as saved, float32); a ValueError naming them otherwise."""
    if dtype is not None and dtype not in ANSWER_DTYPES:
        raise ValueError(f"dtype must be one of {', '.join(ANSWER_DTYPES)}; got {dtype!r}")
    return dtype


def resolve_dtype(dtype: str | None) -> str | None:
    """``auto`` as this machine answers it (bfloat16 with native bf16, else float32); any other type as given."""
    if check_dtype(dtype) != "auto":
        return dtype
    from tacreasoner.train.precision import resolve_mixed_precision  # the same hardware test training's "auto" uses

    return "bfloat16" if resolve_mixed_precision("auto") == "bf16" else "float32"


def load_trained(model_dir: str | os.PathLike[str], adapter: str | os.PathLike[str] | None = None,
                 device: str | None = None, dtype: str | None = None) -> tuple[Any, Any]:
    """A saved model + processor (``train`` output ``stage*/model``), optionally with a Stage II adapter on top;
    ``dtype`` (:data:`ANSWER_DTYPES`) casts its weights for answering."""
    from tacreasoner.model.build import load_model
    from tacreasoner.model.stages import load_adapter

    dtype = resolve_dtype(dtype)
    model, processor = load_model(model_dir)
    if adapter is not None:
        model = load_adapter(model, adapter)
    device = device or ("cuda" if torch.cuda.is_available() else "cpu")
    model = model.to(device)
    if dtype is not None:
        model = model.to(ANSWER_DTYPES[dtype])
    return model.eval(), processor


def answerer_id(model_dir: str | os.PathLike[str], bench_dir: str | os.PathLike[str], dtype: str | None = None,
                answers: str = "direct") -> str:
    """Who answers what, as recorded on each prediction line: the model folder (path, weights' size and time, a
    digest of its processor config: :func:`_processor_mark`), the benchmark folder, the answering type where it is
    not float32 and the answering mode where it is not direct (and whether it reads one-clip questions in untrained
    words: ``stepwise.SINGLE_CLIP_MODES``). Item ids repeat across models and benchmark variants, so a resumed file
    must be checked against it rather than mix two runs' answers."""
    model = Path(model_dir).resolve()
    weights = sorted(model.glob("*.safetensors"))
    stamp = ",".join(f"{w.stat().st_size}@{w.stat().st_mtime_ns // 10**9}" for w in weights)
    dtype = resolve_dtype(dtype)
    cast = f"; dtype={dtype}" if dtype not in (None, "float32") else ""
    mode = f"; answers={check_answers(answers)}" if answers != "direct" else ""
    from tacreasoner.evaluate.stepwise import EMBEDDING_MODES, REASKING_MODES, SINGLE_CLIP_MODES

    if answers in SINGLE_CLIP_MODES:  # since 2026-11-29: a folder answered before then is not resumed as if alike
        mode += " (one-clip questions in untrained words read)"
    if answers in REASKING_MODES:  # since 2026-11-29, likewise
        mode += " (a person's comparisons and real-or-fake questions asked again in the benchmark's words)"
    if answers in EMBEDDING_MODES:  # since 2026-11-29 (the hybrid reader), likewise
        mode += " (a sentence embedding reads what the property words do not)"
    return (f"model={model} [{stamp}]{_processor_mark(model)}; bench={Path(bench_dir).resolve()}"
            f"{_bench_version(Path(bench_dir))}{cast}{mode}")


def _processor_mark(model: Path) -> str:
    """A digest of the model folder's saved processor config (how frames are prepared and prompts are built: the
    colour map, orientation, frames, system prompt, ...), which changes without touching the weights — recorded
    after training (``gel_reference``, ``answers``) or edited by hand (``orientation``, as docs/real-data.md suggests
    for old folders) — so answers prepared one way are never resumed as another's. Empty where none is saved."""
    from tacreasoner.model.processing import saved_processor_config

    config = saved_processor_config(model)
    if not config:
        return ""
    digest = hashlib.sha256(json.dumps(config, sort_keys=True).encode("utf-8")).hexdigest()[:12]
    return f" processor={digest}"


def _bench_version(bench_dir: Path) -> str:
    """`` v2`` from the folder's bench.json (a rebuilt benchmark of another version asks other items under the same
    ids), empty where there is none to read."""
    try:
        version = json.loads((bench_dir / "bench.json").read_text()).get("version")
    except (OSError, ValueError, AttributeError):
        return ""
    return f" v{version}" if version is not None else ""


def check_answers(answers: str) -> str:
    """``answers`` if it is a known answering mode; a ValueError naming them otherwise."""
    if answers not in ANSWER_MODES:
        raise ValueError(f"answers must be one of {', '.join(ANSWER_MODES)}; got {answers!r}")
    return answers


def check_touch(touch: str) -> str:
    """``touch`` if it is a known mode; a ValueError naming the allowed ones otherwise."""
    if touch not in TOUCH_MODES:
        raise ValueError(f"touch must be one of {', '.join(TOUCH_MODES)}; got {touch!r}")
    return touch


def predictions_path(out_dir: str | os.PathLike[str], split: str, touch: str = "real") -> Path:
    """``<out>/predictions/<split>.jsonl`` (real touch) or ``<split>_<touch>.jsonl``: one directory holds all modes."""
    check_touch(touch)
    name = split if touch == "real" else f"{split}_{touch}"
    return Path(out_dir) / "predictions" / f"{name}.jsonl"


def _done_ids(path: Path, touch: str = "real", touch_seed: int | None = None, answered_by: str | None = None,
              ) -> set[str]:
    """Ids already answered; raises when the file was written with another touch mode (or shuffle seed) or by another
    model or benchmark (``answered_by``, where both the line and the run record one), since resuming would mix two
    runs in one file. Lines without ``touch`` predate it and were real touch."""
    if not path.is_file():
        return set()
    done = set()
    with path.open(encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            try:
                record = json.loads(line)
                item_id = record["id"]
            except (json.JSONDecodeError, KeyError, TypeError):
                continue  # a line cut by a crash: the item is answered again
            mode, seed = record.get("touch", "real"), record.get("touch_seed")
            if mode != touch or (touch == "shuffled" and seed != touch_seed):
                found = mode + (f" (touch_seed {seed})" if mode == "shuffled" else "")
                wanted = touch + (f" (touch_seed {touch_seed})" if touch == "shuffled" else "")
                raise ValueError(f"{path}:{number}: predictions made with touch={found}, this run asks for "
                                 f"touch={wanted}; write them to another file rather than mix the two")
            before = record.get("answered_by")
            if answered_by is not None and before is not None and before != answered_by:
                raise ValueError(f"{path}:{number}: predictions made by {before}, this run is {answered_by}; "
                                 f"write them to another --out rather than mix the two")
            done.add(item_id)
    return done


def shuffle_videos(keys: Mapping[str, Sequence[VideoKey]], seed: int = 0,
                   objects: Mapping[str, Sequence[str]] | None = None) -> dict[str, list[VideoKey]]:
    """Each item's videos replaced by other items' videos: a seeded permutation of all video slots of the split,
    so every item keeps its number of videos and every video is used as often as before.

    Where possible no item gets back one of its own clips (conflict 2: items often share clips, so a plain
    derangement of slots would hand many their real touch back) nor another clip of one of its objects
    (conflict 1; an item's objects come from ``objects``, a clip's object from items that list one per video).
    A random permutation is repaired by swaps that lower the total conflict until none does, so the result
    depends only on ``keys``, ``objects`` and ``seed``; where conflicts cannot all be avoided (one item, or
    every clip of one object) the rest stay."""
    ids = list(keys)
    objects = objects or {}
    slot_item = np.array([n for n, item_id in enumerate(ids) for _ in keys[item_id]], dtype=np.int64)
    videos = [v for item_id in ids for v in keys[item_id]]
    clips = {path: n for n, path in enumerate(dict.fromkeys(v[0] for v in videos))}
    clip_object: dict[str, str] = {}
    for item_id in ids:
        if len(objects.get(item_id, ())) == len(keys[item_id]):  # one object per video: each clip's is known
            clip_object.update({v[0]: name for v, name in zip(keys[item_id], objects[item_id], strict=True)})
    names = {name: n for n, name in enumerate(dict.fromkeys([*clip_object.values(),
                                                             *(o for i in ids for o in objects.get(i, ()))]))}
    video_clip = np.array([clips[v[0]] for v in videos], dtype=np.int64)
    video_object = np.array([names.get(clip_object.get(v[0], ""), -1) for v in videos], dtype=np.int64)
    own_clips = [np.array(sorted({clips[v[0]] for v in keys[i]}), dtype=np.int64) for i in ids]
    own_objects = [np.array(sorted({names[o] for o in objects.get(i, ())}), dtype=np.int64) for i in ids]
    holders_clip = _holders(own_clips, len(clips))
    holders_object = _holders(own_objects, len(names))

    def given(item: int, clip: np.ndarray, obj: np.ndarray) -> np.ndarray:
        """Conflict of handing ``item`` the videos of clips ``clip`` (objects ``obj``)."""
        same = np.isin(clip, own_clips[item])
        return np.where(same, 2, np.isin(obj, own_objects[item]) & (obj >= 0))

    def received(slot_items: np.ndarray, clip: int, obj: int) -> np.ndarray:
        """Conflict of handing each of ``slot_items`` the video of ``clip`` (object ``obj``)."""
        same = np.isin(slot_items, holders_clip[clip])
        return np.where(same, 2, np.isin(slot_items, holders_object[obj]) if obj >= 0 else 0)

    rng = random.Random(seed)
    source = list(range(len(videos)))  # slot i gets videos[source[i]]
    rng.shuffle(source)
    src = np.array(source, dtype=np.int64)
    current = np.array([given(int(slot_item[i]), video_clip[src[i:i + 1]], video_object[src[i:i + 1]])[0]
                        for i in range(len(src))], dtype=np.int64)
    improved = True
    while improved:  # every swap lowers the total conflict: this ends
        improved = False
        for i in np.flatnonzero(current):
            if current[i] == 0:  # a swap since the scan began fixed it
                continue
            take = given(int(slot_item[i]), video_clip[src], video_object[src])  # slot i gets slot j's video
            give = received(slot_item, int(video_clip[src[i]]), int(video_object[src[i]]))  # j gets i's
            delta = take + give - current[i] - current
            if delta.min() >= 0:
                continue
            best = np.flatnonzero(delta == delta.min())
            j = int(best[rng.randrange(len(best))])
            src[i], src[j] = src[j], src[i]
            current[i], current[j] = take[j], give[j]
            improved = True
    out: dict[str, list[VideoKey]] = {item_id: [] for item_id in ids}
    for item, k in zip(slot_item, src, strict=True):
        out[ids[item]].append(videos[k])
    return out


def _holders(owned: Sequence[np.ndarray], size: int) -> list[np.ndarray]:
    """For each clip (or object) index, the items that own it."""
    holders: list[list[int]] = [[] for _ in range(size)]
    for item, values in enumerate(owned):
        for v in values.tolist():
            holders[v].append(item)
    return [np.array(h, dtype=np.int64) for h in holders]


def blank_video(video_config: Any) -> torch.Tensor:
    """The preprocessed form of a clip whose frames never change (the gel at rest): T×3×H×W, zeros with the
    default normalisation. Made by the same preprocessing as real clips so it stays what a featureless clip gives."""
    from tacreasoner.model.video_processing import preprocess_video

    height, width = video_config.image_size
    frames = np.zeros((video_config.num_frames, height, width, 3), dtype=np.uint8)
    return torch.from_numpy(preprocess_video(frames, video_config))


@torch.no_grad()
def set_aside_stale(path: Path, who: str) -> Path | None:
    """Move a predictions file aside (``<name>.stale.jsonl``, replacing an older one) when any of its lines was
    answered by another model or benchmark version than ``who``, or records no answerer: a re-run after retraining or
    after a benchmark rebuilt at a new version asks the same ids anew, and resuming would score old answers against
    new items. Returns where it went (None: nothing to move). The quickstart's policy, which owns its folder;
    :func:`predict_items` refuses such a file instead, since an ``--out`` given by hand may hold answers worth keeping
    apart."""
    if not path.is_file():
        return None
    with path.open(encoding="utf-8") as f:
        stale = any(_answerer(line, who) != who for line in f)
    return path.replace(path.with_name(f"{path.stem}.stale.jsonl")) if stale else None


def _answerer(line: str, default: str) -> str | None:
    """Who answered one prediction line (None: nobody recorded); ``default`` for a line cut by a crash, whose item
    ``predict_items`` answers again anyway."""
    try:
        return json.loads(line).get("answered_by")
    except (json.JSONDecodeError, AttributeError):
        return default


def predict_items(model: Any, processor: Any, items: Sequence[QAItem], video_root: str | os.PathLike[str],
                  out_path: str | os.PathLike[str], *, batch_size: int = 32, max_new_tokens: int = REPLY_TOKENS,
                  progress: Callable[[int, int], None] | None = None,
                  video_cache: str | os.PathLike[str] | None = None, touch: str = "real",
                  touch_seed: int = 0, answered_by: str | None = None, answers: str = "direct") -> Path:
    """Greedy answers for ``items`` appended to ``out_path`` (items already there are skipped).

    ``video_cache``: the training run's preprocessed-video directory, reused when given.
    ``touch``: ``real`` (the item's videos), ``blank`` (every video a featureless clip, sensor ids kept) or
    ``shuffled`` (the videos of other items of ``items``, see :func:`shuffle_videos`, drawn from ``touch_seed``);
    each line records it, and a file written with another mode is refused rather than resumed.
    ``answered_by`` (:func:`answerer_id`): recorded on each line; a file answered by another model or benchmark is
    refused rather than resumed.
    ``answers``: ``direct`` (one pass per item) or ``stepwise`` (questions over several objects answered one video
    and one named object per pass and concluded by the rule, :mod:`tacreasoner.evaluate.stepwise`; their
    sub-replies kept in :func:`steps_path`)."""
    from tacreasoner.train.data import VideoBank, video_key

    check_touch(touch)
    check_answers(answers)
    out = Path(out_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.is_file() and out.read_bytes()[-1:] not in (b"", b"\n"):
        with out.open("a", encoding="utf-8") as f:  # a crash cut the last line: close it so appends stay valid
            f.write("\n")
    done = _done_ids(out, touch, touch_seed, answered_by)
    todo = [item for item in items if item.id not in done]
    root = Path(video_root)
    if touch == "shuffled":  # drawn over all items, not only those left: a resumed run gets the same videos
        own = {item.id: [video_key(v, root, f"item {item.id!r}") for v in item.videos] for item in items}
        keys = shuffle_videos(own, touch_seed, {item.id: item.objects for item in items})
    else:
        keys = {item.id: [video_key(v, root, f"item {item.id!r}") for v in item.videos] for item in todo}
    tag: dict[str, Any] = {"touch": touch} | ({"touch_seed": touch_seed} if touch == "shuffled" else {}) | \
        ({"answered_by": answered_by} if answered_by is not None else {})
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for item in todo for k in keys[item.id]], cache_dir=video_cache)
    blank = blank_video(processor.video_config) if touch == "blank" else None
    base = getattr(model, "get_base_model", lambda: model)()
    encoder = getattr(base, "tactile_encoder", None)
    if blank is None and encoder is not None:  # the frozen appearance branch once per clip, not per question
        bank.cache_appearance(encoder, cache_dir=video_cache)

    def replies(prompts: Sequence[tuple[str, Sequence[VideoKey]]], budget: int = max_new_tokens,
                ) -> Iterator[list[tuple[str, bool]]]:
        return _replies(base, processor, prompts, bank, blank, batch_size, budget)

    if progress is not None:
        progress(len(items) - len(todo), len(items))
    views = _question_views(todo, answers) if answers != "direct" else {}
    reasked = _reasked_questions(views, answers)
    stepwise = [item for item in todo if item.id in views and item.id not in reasked]
    direct = [item for item in todo if item.id not in views]
    again = [item for item in todo if item.id in reasked]
    # similar lengths together: less padding in each generate call
    direct.sort(key=lambda item: (len(item.videos), len(item.question)))
    done_count = len(items) - len(todo)
    with out.open("a", encoding="utf-8") as f:
        for start, answered in zip(range(0, len(direct), batch_size),
                                   replies([(item.question, keys[item.id]) for item in direct]), strict=True):
            chunk = direct[start:start + batch_size]
            for item, (text, was_cut) in zip(chunk, answered, strict=True):
                record = {"id": item.id, "prediction": text, "task": item.task, "cut": was_cut, **tag}
                if touch == "shuffled":  # which clips it was shown, for checking the control
                    record["touch_videos"] = [_key_name(k, root) for k in keys[item.id]]
                f.write(json.dumps(record) + "\n")
            f.flush()
            done_count += len(chunk)
            if progress is not None:
                progress(done_count, len(items))
        if again:
            done_count += _answer_again(again, reasked, keys, replies, tag, f,
                                        lambda n: progress(done_count + n, len(items)) if progress else None)
        if stepwise:
            _answer_stepwise([views[item.id] for item in stepwise], keys, out, replies, tag, f, root, touch, answers,
                             lambda n: progress(done_count + n, len(items)) if progress is not None else None)
    return out


def _question_views(items: Sequence[QAItem], answers: str) -> dict[str, QAItem]:
    """id → the stepwise mode's view of each item it answers (the others, single-clip questions (unless the mode
    reads those in untrained words: ``SINGLE_CLIP_MODES``) and comparisons whose words do not say what they ask, are
    answered in one pass)."""
    from tacreasoner.evaluate.stepwise import (
        EMBEDDING_MODES,
        REASKING_MODES,
        SINGLE_CLIP_MODES,
        TRAINED_ONE_PASS_MODES,
        question_view,
    )

    views = {item.id: question_view(item, single_clip=answers in SINGLE_CLIP_MODES,
                                    trained_one_pass=answers in TRAINED_ONE_PASS_MODES,
                                    reask=answers in REASKING_MODES, embedding=answers in EMBEDDING_MODES)
             for item in items}
    return {item_id: view for item_id, view in views.items() if view is not None}


def _reasked_questions(views: Mapping[str, QAItem], answers: str) -> dict[str, tuple[str, ...]]:
    """id → the benchmark wordings an item in a person's words is asked again in, one pass each
    (``stepwise.REASKING_MODES``); the other views are read stepwise."""
    from tacreasoner.evaluate.stepwise import REASKING_MODES, reasked_questions

    if answers not in REASKING_MODES:
        return {}
    asked = {item_id: reasked_questions(view) for item_id, view in views.items()}
    return {item_id: questions for item_id, questions in asked.items() if questions}


def _answer_again(items: Sequence[QAItem], reasked: Mapping[str, Sequence[str]], keys: Mapping[str, Any],
                  replies: Callable[..., Iterator[list[tuple[str, bool]]]], tag: Mapping[str, Any], f: Any,
                  progress: Callable[[int], None] | None) -> int:
    """Answer each item in the benchmark wordings it is asked again in (one pass each, its own videos) and write
    one record per item: the reply whose answer is the majority's (``stepwise.pick_reasked``), with the wording it
    answered under ``asked_as`` (and every wording's reply under ``asked_again`` where there are several)."""
    from tacreasoner.evaluate.stepwise import pick_reasked

    prompts = [(item, question) for item in items for question in reasked[item.id]]
    got = [reply for chunk in replies([(q, keys[item.id]) for item, q in prompts]) for reply in chunk]
    by_item: dict[str, list[tuple[str, str, bool]]] = {}
    for (item, question), (text, was_cut) in zip(prompts, got, strict=True):
        by_item.setdefault(item.id, []).append((question, text, was_cut))
    for n, item in enumerate(items, 1):
        answers = by_item[item.id]
        question, text, was_cut = answers[pick_reasked([t for _, t, _ in answers])]
        record = {"id": item.id, "prediction": text, "task": item.task, "cut": was_cut, **tag, "asked_as": question}
        if len(answers) > 1:
            record["asked_again"] = [{"question": q, "prediction": t} for q, t, _ in answers]
        f.write(json.dumps(record) + "\n")
        if progress is not None:
            progress(n)
    f.flush()
    return len(items)


def _replies(base: Any, processor: Any, prompts: Sequence[tuple[str, Sequence[VideoKey]]], bank: Any,
             blank: torch.Tensor | None, batch_size: int, max_new_tokens: int) -> Iterator[list[tuple[str, bool]]]:
    """Greedy replies to ``prompts`` (question, its videos' keys; no keys for a text-only one), one list of
    (reply, stopped by the budget) per chunk of ``batch_size``."""
    device = next(base.parameters()).device
    eos, pad = processor.eos_token_ids, processor.tokenizer.pad_token_id
    for start in range(0, len(prompts), batch_size):
        chunk = prompts[start:start + batch_size]
        rows = []
        for question, _ in chunk:
            enc = processor.encode_conversation(processor.messages(question), add_generation_prompt=True)
            rows.append({"input_ids": enc.input_ids, "question_mask": enc.question_mask,
                         "pixel_values": torch.zeros(0), "sensor_ids": torch.zeros(0, dtype=torch.long)})
        batch = dict(processor.collate(rows, padding_side="left"))
        # shuffled touch: the keys were swapped by the caller, so each clip's cached tokens follow its pixels
        videos = bank.batch([k for _, chunk_keys in chunk for k in chunk_keys])
        if blank is not None:  # no tokens of the real clips may ride along with the blank ones
            videos.pop("appearance_tokens", None)
            videos["pixel_values"] = blank.unsqueeze(0).repeat(len(videos["sensor_ids"]), 1, 1, 1, 1)
        batch.update(videos)
        batch = {k: v.to(device) for k, v in batch.items()}
        new = base.generate(**batch, max_new_tokens=max_new_tokens, do_sample=False, eos_token_id=eos,
                            pad_token_id=pad)
        texts = processor.tokenizer.batch_decode(new, skip_special_tokens=True)
        yield [(text.strip(), cut) for text, cut in
               zip(texts, _stopped_by_budget(new, eos, max_new_tokens), strict=True)]


def steps_path(out_path: str | os.PathLike[str]) -> Path:
    """Where the stepwise mode keeps its sub-questions' replies beside a predictions file (``<name>.steps.jsonl``)."""
    out = Path(out_path)
    return out.with_name(f"{out.stem}.steps.jsonl")


def _answer_stepwise(items: Sequence[QAItem], keys: Mapping[str, Sequence[VideoKey]], out: Path,
                     replies: Callable[..., Iterator[list[tuple[str, bool]]]],
                     tag: Mapping[str, Any], f: Any, root: Path, touch: str, answers: str,
                     progress: Callable[[int], None]) -> None:
    """Answer ``items`` in the stepwise mode (:mod:`tacreasoner.evaluate.stepwise`): their sub-questions (each asked
    once, kept in :func:`steps_path` so a resumed run asks none twice), then each item's reply composed and written
    to ``f``."""
    from tacreasoner.evaluate.stepwise import STEP_TOKENS, conclude, reading_templates, steps_for

    templates = reading_templates(answers)
    path = steps_path(out)
    said: dict[str, str] = {}
    if path.is_file():
        with path.open(encoding="utf-8") as g:
            for number, line in enumerate(g, 1):
                try:
                    record = json.loads(line)
                    key, reply = record["key"], record["reply"]
                except (json.JSONDecodeError, KeyError, TypeError):
                    continue  # a line cut by a crash: asked again
                if record.get("answered_by") != tag.get("answered_by"):
                    raise ValueError(f"{path}:{number}: sub-questions answered by {record.get('answered_by')}, this "
                                     f"run is {tag.get('answered_by')}; write to another --out rather than mix them")
                said[key] = reply
    steps = {s.key: s for item in items for s in steps_for(item, keys[item.id], templates)}
    todo = sorted((s for s in steps.values() if s.key not in said), key=lambda s: (len(s.videos), len(s.question)))
    with path.open("a", encoding="utf-8") as g:
        start = 0
        for answered in replies([(s.question, s.videos) for s in todo], STEP_TOKENS):
            for step, (text, was_cut) in zip(todo[start:start + len(answered)], answered, strict=True):
                said[step.key] = text
                g.write(json.dumps({"key": step.key, "reply": text, "cut": was_cut,
                                    "answered_by": tag.get("answered_by")}) + "\n")
            g.flush()
            start += len(answered)
            progress(len(items) * start // len(todo) - (start == len(todo)))  # the items follow once all are asked
    for item in items:
        composed = conclude(item, keys[item.id], said, templates)
        record = {"id": item.id, "prediction": composed.reply, "task": item.task, "cut": False, **tag,
                  "answers": answers, "steps": composed.steps, "guessed": composed.guessed}
        if touch == "shuffled":
            record["touch_videos"] = [_key_name(k, root) for k in keys[item.id]]
        f.write(json.dumps(record) + "\n")
    f.flush()
    progress(len(items))


def _stopped_by_budget(new: torch.Tensor, eos: Sequence[int], max_new_tokens: int) -> list[bool]:
    """Per row of ``generate``'s new tokens: did ``max_new_tokens`` end it, before the model ended its turn?"""
    if new.shape[-1] < max_new_tokens:
        return [False] * new.shape[0]
    ended = torch.isin(new, torch.tensor(list(eos), device=new.device)).any(dim=-1)
    return [not bool(e) for e in ended]


def cut_replies(path: str | os.PathLike[str]) -> dict[str, int]:
    """Replies in a predictions file that ``max_new_tokens`` stopped before the model ended them, per task (lines
    written before this was recorded count as not cut)."""
    counts: dict[str, int] = {}
    with Path(path).open(encoding="utf-8") as f:
        for line in f:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue
            if isinstance(record, dict) and record.get("cut"):
                counts[record.get("task", "?")] = counts.get(record.get("task", "?"), 0) + 1
    return counts


def cut_warning(path: str | os.PathLike[str], max_new_tokens: int) -> str | None:
    """One line for the user when replies were stopped by the budget (they score wrong as written), else None."""
    counts = cut_replies(path)
    if not counts:
        return None
    tasks = ", ".join(f"{t} {n}" for t, n in sorted(counts.items(), key=lambda kv: -kv[1]))
    return (f"warning: {sum(counts.values())} replies in {path} hit the reply budget (--max-new-tokens, "
            f"{max_new_tokens} now) before the model ended them ({tasks}); they are scored as written (no <answer>: "
            f"wrong). Answer again with a larger --max-new-tokens into a new --out.")


def _key_name(key: VideoKey, root: Path) -> str:
    """A video key as a short string: its path under ``root`` (when it is), with ``[start:end]`` for a segment."""
    path = Path(key[0])
    name = str(path.relative_to(root)) if path.is_relative_to(root) else str(path)
    return name if key[1] is None and key[2] is None else f"{name}[{key[1] or ''}:{key[2] or ''}]"


def answer_with_model(model_dir: Path, bench: Path, info: Any, items: Sequence[QAItem], path: Path, *,
                      batch_size: int = 32, max_new_tokens: int = REPLY_TOKENS, touch: str = "real",
                      touch_seed: int = 0, video_cache: Path | None = None,
                      progress: Callable[[int, int], None] | None = None, dtype: str | None = None,
                      answers: str = "direct") -> Path:
    """Answer ``items`` of the benchmark ``bench`` (``info``: its ``bench.json``) with the saved model in
    ``model_dir`` (its weights cast to ``dtype``; ``answers``: :data:`ANSWER_MODES`) into ``path``, resuming it. The
    model is loaded only when an item is left to answer, so a finished file costs no model load (a re-run
    quickstart, a resumed evaluation)."""
    from tacreasoner.train.data import bench_video_root

    who = answerer_id(model_dir, bench, dtype, answers)
    if {item.id for item in items} <= _done_ids(path, touch, touch_seed, who):
        return path
    model, processor = load_trained(model_dir, dtype=dtype)
    return predict_items(model, processor, items, bench_video_root(bench, info), path, batch_size=batch_size,
                         max_new_tokens=max_new_tokens, progress=progress, touch=touch, touch_seed=touch_seed,
                         answered_by=who, video_cache=video_cache, answers=answers)


def predict_split(model_dir: Path, bench: Path, split: str, out: Path, *, batch_size: int = 32,
                  max_new_tokens: int = REPLY_TOKENS, limit: int | None = None, touch: str = "real",
                  touch_seed: int = 0, video_cache: Path | None = None,
                  dtype: str | None = None, answers: str = "direct") -> tuple[list[QAItem], Path]:
    """Answer one split of a benchmark with a saved model into ``out``'s predictions file (resuming it), with a
    progress display; returns the items asked and the predictions path. ``video_cache``: a preprocessed-video
    folder to read and fill (a training run's), so that models answering the same clips decode them once.
    ``dtype``: the weights' type when answering (:data:`ANSWER_DTYPES`); ``answers``: :data:`ANSWER_MODES`."""
    from tacreasoner.progress import ClipProgress
    from tacreasoner.tasks.bench import load_bench

    info, items = load_bench(bench, split)
    items = items[:limit] if limit else items
    if not items:
        raise ValueError(f"{bench}: split {split!r} has no items")
    path = predictions_path(out, split, touch)
    label = split if touch == "real" else f"{split} ({touch} touch)"
    with ClipProgress(f"answering {label}", "items") as bar:
        answer_with_model(model_dir, bench, info, items, path, batch_size=batch_size, max_new_tokens=max_new_tokens,
                          touch=touch, touch_seed=touch_seed, video_cache=video_cache, progress=bar, dtype=dtype,
                          answers=answers)
    return items, path
