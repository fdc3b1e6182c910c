"""Training data for Stages I and II: examples, their videos (preprocessed once), and a resumable batch plan.

- Stage I (alignment) learns to *describe* a clip: the benchmark's train split items that are about one
  clip (TFA attributes and combined, real vs fake, contact state), like VTV-150K's raw instruction data,
  written as ``<answer>…</answer>`` (the LLM is frozen in Stage I: it already knows the answer format, so
  the tactile side only has to supply the content; plain text put the loss on format it cannot learn).
- Stage II (SFT) learns to reason: TouchCoT records (``<think>…</think><answer>…</answer>``); the compact
  describe-then-conclude reasoning written from the train items' labels (``stage2_data: compact``); or, for the
  paper's "w/o CoT" ablation, the same train items answered with ``<answer>gold</answer>`` only.

Videos are preprocessed deterministically (uniform sampling, no jitter) once per clip or segment and kept
in memory, so an epoch never decodes video again and the frozen ViT's tokens can be cached too.
The batch plan is a pure function of (seed, step): a resumed or multi-process run sees exactly the
examples an uninterrupted single-process run would.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import random
from collections import Counter
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from tacreasoner.cot.compact import compact_target
from tacreasoner.cot.rulebank import RulesBank, load_bank
from tacreasoner.model.processing import IGNORE_INDEX
from tacreasoner.model.video_processing import sensor_index
from tacreasoner.tasks.schema import PLACEHOLDER, TFA_TASKS, QAItem, VideoRef

__all__ = ["STAGE1_TASKS", "TooLong", "TrainExample", "VideoBank", "batch_plan", "batch_purity", "left_out_by_task",
           "load_examples", "padding_fraction", "tokenize_examples"]

STAGE1_TASKS = (*TFA_TASKS, "RFOR", "OCSE")
"""Single-clip description tasks: Stage I's alignment data."""

COMPARISON_TASKS = ("SFD", "SOI")
"""Multi-video tasks Stage I adds with ``data.stage1_comparisons``."""

VideoKey = tuple[str, int | None, int | None]


@dataclass(frozen=True)
class TrainExample:
    key: str
    task: str
    question: str
    target: str
    videos: tuple[VideoKey, ...]
    """(absolute video path, segment start, segment end) per ``<tactile>``, in order."""
    winner: int = IGNORE_INDEX
    """SFD/SOI: the place (0-based) of the video the question picks, for ``encoder.cross_video``'s comparator."""
    attribute: str = ""
    """SFD/SOI: the attribute compared."""
    more: int = IGNORE_INDEX
    """SFD/SOI: 1 when the question asks for more of it (harder, the most elastic), 0 for less."""
    assignment: tuple[int, ...] = ()
    """OSC: each video's option index (the name it was recorded on), for the cross-video layer's name matcher."""


def comparison_target(item: QAItem) -> dict[str, Any]:
    """An SFD/SOI item's comparator targets (``winner``, ``attribute``, ``more``), an OSC item's ``assignment``
    (for the name matcher); empty for other tasks."""
    if item.task == "OSC":
        return {"assignment": tuple(int(k) for k in item.gold["assignment"])}
    if item.task not in COMPARISON_TASKS:
        return {}
    return {"winner": comparison_winner(item), "attribute": str(item.gold["attribute"]),
            "more": int(item.gold["direction"] in ("more", "most"))}


def comparison_winner(item: QAItem) -> int:
    """The place of the video an SFD/SOI item's question picks (yes/no: the first if "yes"), else IGNORE_INDEX."""
    if item.task not in COMPARISON_TASKS:
        return IGNORE_INDEX
    if item.gold.get("kind") == "yesno":
        return 0 if item.gold["value"] else 1
    return int(item.gold["index"])


def video_key(ref: VideoRef, root: Path, where: str) -> VideoKey:
    if not ref.path:
        raise ValueError(f"{where}: video {ref.clip_id!r} has no path")
    path = Path(ref.path)
    path = path if path.is_absolute() else root / path
    if not path.is_file():
        raise FileNotFoundError(f"{where}: video {ref.clip_id!r} not found at {path}")
    return (str(path), ref.start, ref.end)


def train_items(bench_dir: Path) -> tuple[Path, list[QAItem]]:
    """The benchmark's train split and the root its relative video paths start from."""
    from tacreasoner.tasks.bench import load_bench

    info, items = load_bench(bench_dir, "train")
    return bench_video_root(bench_dir, info), items


def bench_video_root(bench_dir: Path, info: dict) -> Path:
    """Where a benchmark's relative video paths start (``video_root`` in bench.json; absolute when built)."""
    root = Path(info.get("video_root") or bench_dir)
    return root if root.is_absolute() else bench_dir / root


def _from_items(items: Sequence[QAItem], root: Path, target: Callable[[QAItem], str]) -> list[TrainExample]:
    return [TrainExample(key=item.id, task=item.task, question=item.question, target=target(item),
                         videos=tuple(video_key(v, root, f"item {item.id!r}") for v in item.videos),
                         **comparison_target(item))
            for item in items]


def _touchcot(path: Path, root: Path, items: Sequence[QAItem] = ()) -> list[TrainExample]:
    """TouchCoT records; ``items`` (the benchmark's train split) gives comparisons their gold pick."""
    targets = {i.id: comparison_target(i) for i in items}
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no TouchCoT training file (run `tacreasoner build-cot`, or set "
                                f"data.stage2_data: plain)")
    out = []
    with path.open(encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if not line.strip():
                continue
            where = f"{path}:{number}"
            try:
                record = json.loads(line)
                refs = [VideoRef(**v) if isinstance(v, dict) else VideoRef(clip_id=str(v), path=str(v))
                        for v in record["videos"]]
                out.append(TrainExample(key=str(record["id"]), task=str(record["task"]),
                                        question=str(record["question"]), target=str(record["output"]),
                                        videos=tuple(video_key(r, root, where) for r in refs),
                                        **targets.get(str(record.get("item_id")), {})))
            except (json.JSONDecodeError, KeyError, TypeError) as exc:
                raise ValueError(f"{where}: not a TouchCoT training record ({type(exc).__name__}: {exc}); "
                                 f"expected id, task, question, videos, output") from None
    return out


def _reworded(items: Sequence[QAItem], letters: bool = True) -> list[QAItem]:
    from tacreasoner.tasks.paraphrase import reword_items

    return reword_items(items, "train", letters=letters)


def _reworded_touchcot(examples: Sequence[TrainExample], items: Sequence[QAItem], root: Path
                       ) -> list[TrainExample]:
    """A copy of each TouchCoT example whose item (same question, same videos) has a same-answer training wording,
    asked in it."""
    def videos(item: QAItem) -> tuple[VideoKey, ...]:
        return tuple(video_key(v, root, f"item {item.id!r}") for v in item.videos)

    reworded = {i.id.removesuffix("-train"): i.question for i in _reworded(items, letters=False)}
    item_of = {(i.question, videos(i)): i.id for i in items if i.id in reworded}
    out = []
    for e in examples:
        item_id = item_of.get((e.question, e.videos))
        if item_id is not None:
            out.append(dataclasses.replace(e, key=f"{e.key}-train", question=reworded[item_id]))
    return out


def _answer_only(item: QAItem) -> str:
    return f"<answer>{item.answer}</answer>"


def reading_question(n_videos: int, video: int, attribute: str) -> str:
    """A question about one video (from 1) of several: what Stage I's video readings ask
    (``data.stage1_video_readings``)."""
    return "\n".join([PLACEHOLDER] * n_videos) + f"\nHow does Video {video} feel in {attribute}?"


def reading_word(attribute: str, rank: int, bank: RulesBank | None = None) -> str:
    """The answer to a reading question: the teacher's first descriptor of that level."""
    return (bank or load_bank()).data["descriptors"][attribute][int(rank)][0]


def video_reading_items(items: Sequence[Any]) -> list[tuple[Any, int]]:
    """(item, video index) for every video of every SFD/SOI item with per-video levels."""
    out = []
    for item in items:
        ranks = item.meta.get("ranks")
        if item.task in ("SFD", "SOI") and isinstance(ranks, list) and len(ranks) == len(item.videos) \
                and all(isinstance(r, int) for r in ranks) and item.meta.get("attribute"):
            out += [(item, v) for v in range(len(ranks))]
    return out


def _video_readings(items: Sequence[QAItem], root: Path) -> list[TrainExample]:
    out = []
    for item, v in video_reading_items(items):
        attribute, ranks = item.meta["attribute"], item.meta["ranks"]
        out.append(TrainExample(key=f"{item.id}#video{v + 1}", task=f"{item.task}-reading",
                                question=reading_question(len(ranks), v + 1, attribute),
                                target=f"<answer>{reading_word(attribute, ranks[v])}</answer>",
                                videos=tuple(video_key(r, root, f"item {item.id!r}") for r in item.videos)))
    return out


def text_knowledge(bench: Path, train: Sequence[QAItem], knowledge: str = "none", scenario_knowledge: bool = False,
                   seed: int = 0) -> list[TrainExample]:
    """Text-only Stage II examples in the benchmark's vocabulary (``cot.knowledge``): what everyday objects feel like
    (``knowledge`` all, or without_eval_names: no entry sharing a word with a val or test object's name; entries named
    like one of the ``train`` items' objects never) and, with ``scenario_knowledge``, what training scenarios need."""
    from tacreasoner.cot.knowledge import KNOWLEDGE, knowledge_examples, scenario_examples
    from tacreasoner.tasks.bench import load_bench

    if knowledge not in KNOWLEDGE:
        raise ValueError(f"data.knowledge must be one of {', '.join(KNOWLEDGE)}, got {knowledge!r}")
    if knowledge == "none" and not scenario_knowledge:
        return []
    vocabulary = json.loads((bench / "bench.json").read_text(encoding="utf-8"))["vocabulary"]

    def names(items: Sequence[QAItem]) -> list[str]:
        return [n for i in items for n in (*i.meta.get("object_names", ()), *i.objects)]

    out = []
    if knowledge != "none":
        exclude = []
        if knowledge == "without_eval_names":
            exclude = [n for split in ("val", "test") for n in names(load_bench(bench, split)[1])]
        out += [TrainExample(key=e.key, task="knowledge", question=e.question, target=e.target, videos=())
                for e in knowledge_examples(vocabulary, exclude=exclude, train_names=names(train), seed=seed)]
    if scenario_knowledge:
        out += [TrainExample(key=e.key, task="scenario knowledge", question=e.question, target=e.target, videos=())
                for e in scenario_examples(vocabulary, seed=seed)]
    return out


def load_examples(stage: int, bench: str | Path, *, touchcot: str | Path | None = None, stage2_data: str = "touchcot",
                  tasks: Sequence[str] | None = None, max_items: int | None = None,
                  video_readings: bool = False, comparisons: bool = False, paraphrases: bool = False,
                  knowledge: str = "none", scenario_knowledge: bool = False) -> list[TrainExample]:
    """The examples of ``stage`` (see the module doc); TSA is never among them. ``paraphrases``: each item is also
    asked in one of its training wordings (``tasks.paraphrase``). ``knowledge`` (Stage II): text-only examples of
    what everyday objects feel like; ``scenario_knowledge`` (Stage II): text-only examples of what training scenarios
    need (never TSA's evaluation scenarios); both :func:`text_knowledge`."""
    bench = Path(bench)
    root, items = train_items(bench)
    items = [i for i in items if i.task != "TSA"]
    if stage == 1:
        wanted = (*STAGE1_TASKS, *COMPARISON_TASKS) if comparisons else STAGE1_TASKS
        chosen = [i for i in items if i.task in wanted]
        examples = _from_items(chosen + (_reworded(chosen) if paraphrases else []), root, _answer_only)
        if video_readings:
            examples += _video_readings(items, root)
    elif stage2_data in ("plain", "compact"):
        target = _answer_only if stage2_data == "plain" else compact_target
        examples = _from_items(items + (_reworded(items) if paraphrases else []), root, target)
    else:
        if touchcot is None:
            raise ValueError("data.touchcot: Stage II on TouchCoT needs the training JSONL from build-cot")
        examples = [e for e in _touchcot(Path(touchcot), root, items) if e.task != "TSA"]
        if paraphrases:  # the reasoning and answer stay: only wordings whose answer form is the template's
            examples += _reworded_touchcot(examples, items, root)
    if tasks is not None:
        examples = [e for e in examples if e.task in set(tasks)]
    if stage == 2:
        examples += text_knowledge(bench, items, knowledge, scenario_knowledge)
    if max_items is not None:
        examples = examples[:max_items]
    if not examples:
        raise ValueError(f"stage {stage}: no training examples (bench {bench}, tasks {list(tasks or []) or 'all'})")
    return examples


# ------------------------------------------------------------------------------------------ tokens


@dataclass
class Tokenized:
    input_ids: list[int]
    labels: list[int]
    question_mask: list[int]
    videos: tuple[VideoKey, ...]
    key: str
    winner: int = IGNORE_INDEX
    attribute: str = ""
    more: int = IGNORE_INDEX
    assignment: tuple[int, ...] = ()
    task: str = ""
    readings: dict[str, Any] | None = None
    """The read-out heads' out-of-fold verdicts on this example (``train.heads``), what Stage II writes."""

    @property
    def n_labels(self) -> int:
        return sum(1 for t in self.labels if t != IGNORE_INDEX)


@dataclass(frozen=True)
class TooLong:
    """An example longer than ``data.max_length``: left out of training, never truncated mid-answer."""

    key: str
    task: str
    length: int


def tokenize_examples(processor: Any, examples: Sequence[TrainExample], max_length: int,
                      system: str | None = None) -> tuple[list[Tokenized], list[TooLong]]:
    """Token ids + labels (assistant only) for each example; those over ``max_length`` are returned apart."""
    kept, dropped = [], []
    for e in examples:
        enc = processor.encode_conversation(processor.messages(e.question, e.target, system),
                                            add_generation_prompt=False)
        if len(enc.input_ids) > max_length:
            dropped.append(TooLong(e.key, e.task, len(enc.input_ids)))
            continue
        kept.append(Tokenized(enc.input_ids, enc.labels, enc.question_mask, e.videos, e.key, e.winner, e.attribute,
                              e.more, e.assignment, e.task))
    return kept, dropped


def left_out_by_task(examples: Sequence[TrainExample], dropped: Sequence[TooLong], max_length: int) -> dict[str, int]:
    """Per task, how many examples ``max_length`` leaves out. A task that loses every example is an error: the
    model would silently never see it (long TouchCoT reasoning over 3 videos at the plain-answer recipe's 320
    tokens lost every OSC and combined-attribute example)."""
    left_out = Counter(d.task for d in dropped)
    total = Counter(e.task for e in examples)
    lost = sorted(t for t, n in left_out.items() if n == total[t])
    if lost:
        longest = max(d.length for d in dropped if d.task in lost)
        raise ValueError(f"data.max_length={max_length} leaves out every example of {', '.join(lost)} (the longest "
                         f"is {longest} tokens): raise data.max_length to at least {longest}, or leave the task "
                         f"out with data.tasks")
    return dict(sorted(left_out.items()))


def repeat_tasks(examples: Sequence[Tokenized], repeat: dict[str, int] | None) -> list[Tokenized]:
    """``examples`` with each example of a task in ``repeat`` that many times (in place, so order stays)."""
    if not repeat:
        return list(examples)
    return [e for e in examples for _ in range(repeat.get(e.task, 1))]


# ------------------------------------------------------------------------------------------ videos


class VideoBank:
    """Preprocessed videos (and optionally the frozen ViT's tokens), computed once per clip or segment."""

    def __init__(self, video_config: Any, sensor_types: Sequence[str]) -> None:
        self.video_config = video_config
        self.sensor_types = list(sensor_types)
        self.index: dict[VideoKey, int] = {}
        self.pixels: torch.Tensor | None = None
        self.sensors: torch.Tensor | None = None
        self.appearance: torch.Tensor | None = None

    def build(self, keys: Sequence[VideoKey], progress: Callable[[int, int], None] | None = None,
              cache_dir: str | Path | None = None, workers: int | None = None) -> None:
        """Preprocess every distinct video once; ``cache_dir`` keeps the results on disk for later runs
        (other stages, seeds, ablations and evaluation), keyed by file, size, mtime, segment and settings.

        Clips not on disk yet are decoded by ``workers`` processes (default: 2 where the cores allow and no
        distributed run shares them), each clip once for all its segments: decoding is most of the work and
        runs on one core per process.
        """
        # sorted by file: the segments of one clip follow each other
        unique = sorted(dict.fromkeys(keys), key=lambda k: (k[0], k[1] or 0, k[2] or 0))
        cache = Path(cache_dir) if cache_dir is not None else None
        arrays: dict[VideoKey, np.ndarray] = {}
        todo: dict[str, list[VideoKey]] = {}
        files = {key: _cache_file(key, self.video_config, cache) for key in unique}
        for key in unique:
            hit = _load_cached(files[key])
            if hit is None:
                todo.setdefault(key[0], []).append(key)
            else:
                arrays[key] = hit

        def report() -> None:
            if progress is not None:
                progress(len(arrays), len(unique))

        report()
        jobs = [(path, clip_keys, self.video_config, [files[k] for k in clip_keys])
                for path, clip_keys in todo.items()]
        for clip_keys, clip_arrays in _run_clip_jobs(jobs, _video_workers(workers)):
            arrays.update(zip(clip_keys, clip_arrays, strict=True))
            report()
        self.index = {k: i for i, k in enumerate(unique)}
        self.pixels = torch.from_numpy(np.stack([arrays[k] for k in unique])) if unique else None
        # clips/<sensor>/<clip>
        self.sensors = torch.tensor([sensor_index(Path(k[0]).parent.name, self.sensor_types) for k in unique],
                                    dtype=torch.long)

    @torch.no_grad()
    def cache_appearance(self, tactile_encoder: Any, batch_size: int = 64, cache_dir: str | Path | None = None,
                         progress: Callable[[int, int], None] | None = None) -> torch.Tensor | None:
        """Run the frozen appearance branch once over every video (identical to running it each step); returns the
        tokens before standardisation. ``cache_dir`` keeps them on disk, keyed by the video and by the branch's
        weights and pooling, so the next stage, seed or variant on the same encoder reads them back."""
        if self.pixels is None:
            return None
        raw = self.appearance_tokens(tactile_encoder, batch_size, standardized=False, cache_dir=cache_dir,
                                     progress=progress)
        self.appearance = tactile_encoder.standardize(raw)
        return raw

    @torch.no_grad()
    def appearance_tokens(self, tactile_encoder: Any, batch_size: int = 64, *, standardized: bool = True,
                          cache_dir: str | Path | None = None,
                          progress: Callable[[int, int], None] | None = None) -> torch.Tensor:
        """The frozen appearance branch's tokens (``appearance_tokens``) of every video of the bank, in its order;
        ``progress(done, total)`` after each batch (a pretrained backbone over every clip takes minutes on a CPU)."""
        assert self.pixels is not None
        keys = sorted(self.index, key=self.index.__getitem__)
        files = _appearance_files(keys, self.video_config, tactile_encoder, cache_dir)
        cached = [_load_cached(f) for f in files]
        todo = [i for i, hit in enumerate(cached) if hit is None]
        if progress is not None:
            progress(len(cached) - len(todo), len(cached))
        param = next(tactile_encoder.appearance.parameters())
        for start in range(0, len(todo), batch_size):
            chunk = todo[start:start + batch_size]
            pixels = self.pixels[torch.tensor(chunk)].to(param.device, param.dtype)
            tokens = tactile_encoder.appearance_tokens(pixels, standardized=False).float().cpu().numpy()
            for i, array in zip(chunk, tokens, strict=True):
                cached[i] = array
                _save_array(files[i], array)
            if progress is not None:
                progress(len(cached) - len(todo) + start + len(chunk), len(cached))
        raw = torch.from_numpy(np.stack(cached)).to(param.dtype)
        return tactile_encoder.standardize(raw) if standardized else raw

    def batch(self, keys: Sequence[VideoKey]) -> dict[str, torch.Tensor]:
        assert self.pixels is not None and self.sensors is not None
        idx = torch.tensor([self.index[k] for k in keys], dtype=torch.long)
        out = {"pixel_values": self.pixels[idx], "sensor_ids": self.sensors[idx]}
        if self.appearance is not None:
            out["appearance_tokens"] = self.appearance[idx]
        return out


def collate(processor: Any, examples: Sequence[Tokenized], bank: VideoBank,
            attributes: Sequence[str] | None = None) -> dict[str, Any]:
    """Right-padded ids/labels/masks plus the videos of every example, in order (what the model expects); given
    the comparator's ``attributes``, also each comparison's targets for it (``video_winner``, B×3: the gold pick,
    the index of its attribute in ``attributes`` and whether it asks for more; IGNORE_INDEX where unknown)."""
    batch = processor.collate([{"input_ids": e.input_ids, "labels": e.labels, "question_mask": e.question_mask,
                                "pixel_values": torch.zeros(0), "sensor_ids": torch.zeros(0, dtype=torch.long)}
                               for e in examples])
    batch = dict(batch)
    batch.update(bank.batch([k for e in examples for k in e.videos]))
    if attributes is not None:
        batch["video_winner"] = comparison_targets(examples, attributes)
    if any(e.readings for e in examples):
        batch["readings"] = head_readings(examples)
    return batch


def head_readings(examples: Sequence[Tokenized]) -> dict[str, torch.Tensor]:
    """The examples' read-out head verdicts as the model takes them (``model.heads.base.READINGS``): ``levels``
    V×traits (−1: none), ``pick`` B×most videos (scores; 0 past a prompt's videos), ``places`` B×most options
    (−1: not matched)."""
    out: dict[str, torch.Tensor] = {}
    given = [e.readings or {} for e in examples]
    if any("levels" in r for r in given):
        traits = next(r["levels"].shape[1] for r in given if "levels" in r)
        out["levels"] = torch.cat([r["levels"] if "levels" in r else torch.full((len(e.videos), traits), -1)
                                   for e, r in zip(examples, given, strict=True)]).long()
    if any("pick" in r for r in given):
        pick = torch.zeros(len(examples), max(len(e.videos) for e in examples))
        for i, r in enumerate(given):
            if "pick" in r:
                pick[i, :len(r["pick"])] = r["pick"].float()
        out["pick"] = pick
    if any("places" in r for r in given):
        places = torch.full((len(examples), max(len(r.get("places", ())) for r in given)), -1, dtype=torch.long)
        for i, r in enumerate(given):
            if "places" in r:
                places[i, :len(r["places"])] = r["places"]
        out["places"] = places
    return out


def comparison_targets(examples: Sequence[Tokenized], attributes: Sequence[str]) -> torch.Tensor:
    """B×3: each example's gold pick, its attribute's index in ``attributes`` and whether it asks for more."""
    index = {a: i for i, a in enumerate(attributes)}
    return torch.tensor([[e.winner, index.get(e.attribute, IGNORE_INDEX), e.more] for e in examples],
                        dtype=torch.long)


def _cache_file(key: VideoKey, video_config: Any, cache_dir: Path | None) -> Path | None:
    if cache_dir is None:
        return None
    path, start, end = key
    stat = Path(path).stat()
    name = json.dumps([str(Path(path).resolve()), stat.st_size, stat.st_mtime_ns, start, end,
                       video_config.to_dict()], sort_keys=True)
    return cache_dir / f"{hashlib.sha256(name.encode()).hexdigest()[:24]}.npy"


def _appearance_files(keys: Sequence[VideoKey], video_config: Any, tactile_encoder: Any,
                      cache_dir: str | Path | None) -> list[Path | None]:
    """Per video the disk-cache file of its appearance tokens: the video's own key plus a digest of the frozen
    branch's weights and token pooling (another encoder never reads them)."""
    if cache_dir is None:
        return [None] * len(keys)
    digest = hashlib.sha256(str(tactile_encoder.config.tokens_per_video).encode())
    for name, tensor in sorted(tactile_encoder.appearance.state_dict().items()):
        digest.update(name.encode())
        digest.update(tensor.detach().float().cpu().numpy().tobytes())
    folder = Path(cache_dir) / "appearance" / digest.hexdigest()[:16]
    return [folder / f.name if (f := _cache_file(k, video_config, Path(cache_dir))) is not None else None
            for k in keys]


def _save_array(file: Path | None, array: np.ndarray) -> None:
    """Write one cached array atomically (a crash never leaves a torn file under its name); no file, no write."""
    if file is None:
        return
    file.parent.mkdir(parents=True, exist_ok=True)
    tmp = file.with_suffix(f".{os.getpid()}.tmp")
    with tmp.open("wb") as f:
        np.save(f, array)
    os.replace(tmp, file)


def _load_cached(file: Path | None) -> np.ndarray | None:
    if file is None or not file.is_file():
        return None
    try:
        return np.load(file)
    except (OSError, ValueError):
        return None  # a torn write: recompute


def _preprocess_clip(job: tuple[str, list[VideoKey], Any, list[Path | None]]) -> list[np.ndarray]:
    """Every segment of one clip, decoded once; each result written to its disk-cache file when it has one."""
    from tacreasoner.data.cache import load_frames
    from tacreasoner.data.sampling import background_frame
    from tacreasoner.model.video_processing import preprocess_video

    path, keys, video_config, files = job
    try:
        frames = load_frames(path)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path}: cannot decode training video ({exc})") from None
    out = []
    for (_, start, end), cached in zip(keys, files, strict=True):
        segment = frames[start:end] if (start is not None or end is not None) else frames
        if len(segment) == 0:
            raise ValueError(f"{path}: segment [{start}, {end}) holds no frames")
        array = preprocess_video(segment, video_config, background=background_frame(frames))
        _save_array(cached, array)
        out.append(array)
    return out


VIDEO_WORKERS_ENV = "TACREASONER_VIDEO_WORKERS"
"""Decoding processes for a video bank, where the default (2: what a 2-core machine's memory and cores allow) is
too few, e.g. on a 16-core GPU machine."""


def _video_workers(workers: int | None) -> int:
    if workers is not None:
        return max(1, int(workers))
    if os.environ.get(VIDEO_WORKERS_ENV):
        value = os.environ[VIDEO_WORKERS_ENV]
        if not value.isdigit() or int(value) < 1:
            raise ValueError(f"{VIDEO_WORKERS_ENV}={value!r}: expected a whole number of processes, 1 or more")
        return int(value)
    if int(os.environ.get("WORLD_SIZE", "1")) > 1:
        return 1  # each process of a distributed run builds its own bank: the cores are taken
    from tacreasoner.train.threads import available_cores

    return min(2, available_cores())


MIN_CLIPS_PER_POOL = 8
"""Fewer clips than this are decoded in-process: starting worker processes would cost more."""


def _run_clip_jobs(jobs: list, workers: int) -> Iterable[tuple[list[VideoKey], list[np.ndarray]]]:
    """(keys, arrays) per clip job, in order."""
    if workers <= 1 or len(jobs) < MIN_CLIPS_PER_POOL:
        for job in jobs:
            yield job[1], _preprocess_clip(job)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from tacreasoner.data.cache import set_memory_limit

    # workers decode each clip once: keeping its frames in their memory cache would only cost RAM
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                             initializer=set_memory_limit, initargs=(0,)) as pool:
        for job, arrays in zip(jobs, pool.map(_preprocess_clip, jobs, chunksize=4), strict=True):
            yield job[1], arrays


# ------------------------------------------------------------------------------------------ order


def batch_plan(lengths: Sequence[int], global_batch: int, step: int, seed: int, group_by_length: bool,
               group_batches: int = 32) -> list[int]:
    """Example indices of optimizer step ``step`` (global batch), a pure function of its arguments (resume).

    Each epoch is a seeded shuffle; with ``group_by_length`` the shuffle is cut into chunks of
    ``group_batches`` global batches, each sorted by length (less padding), and the batches then shuffled
    again. Length follows task and answer, so the longer the chunk the more a batch holds one task and one
    answer (benchmarks/results/batch_mix.md); 1 is the plain shuffle.
    """
    n = len(lengths)
    if n == 0:
        raise ValueError("no training examples")
    if group_batches < 1:
        raise ValueError(f"group_batches must be at least 1, got {group_batches}")
    per_epoch = max(1, n // global_batch)
    epoch, within = divmod(step, per_epoch)
    order = list(range(n))
    rng = random.Random(seed * 1_000_003 + epoch)
    rng.shuffle(order)
    if n < global_batch:  # tiny data: repeat the shuffled list to fill one batch
        order = (order * (global_batch // n + 1))[:global_batch]
    order = order[: per_epoch * global_batch]
    if group_by_length and group_batches > 1:
        chunk = group_batches * global_batch
        grouped: list[list[int]] = []
        for c in range(0, len(order), chunk):
            part = sorted(order[c:c + chunk], key=lambda i: lengths[i])
            grouped += [part[b:b + global_batch] for b in range(0, len(part), global_batch)]
        rng.shuffle(grouped)
        return grouped[within]
    return order[within * global_batch:(within + 1) * global_batch]


def padding_fraction(lengths: Sequence[int], batches: Iterable[Sequence[int]]) -> float:
    """Share of the padded token grid that is padding (right-padding to each batch's longest)."""
    grid = real = 0
    for batch in batches:
        sizes = [lengths[i] for i in batch]
        grid += max(sizes) * len(sizes)
        real += sum(sizes)
    return 1.0 - real / grid if grid else 0.0


def batch_purity(batches: Iterable[Sequence[int]], labels: Sequence[object]) -> float:
    """Mean share of a batch taken by its most common label (1 = every batch holds one label)."""
    shares = [Counter(labels[i] for i in batch).most_common(1)[0][1] / len(batch) for batch in batches if batch]
    return sum(shares) / len(shares) if shares else 0.0
