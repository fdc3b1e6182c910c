"""Retrieval augmentation (Octopi-1.5's idea, issue 28) as a benchmark transform.

Octopi-1.5 shows the model the training clips that look most like the one it is asked about, with those objects'
labels, in the prompt. Here that is a *benchmark transform*: :func:`retrieval_bench` writes a new benchmark folder
whose questions start with a short text of retrieved neighbours, so training, evaluation and every report take it
without a change of their own.

- **Embedding**: the frozen appearance encoder's CLS token of each video (prepared exactly as the model's inputs
  are, through :class:`tacreasoner.train.data.VideoBank`), L2-normalised; similarity is the cosine.
- **Reference set**: the whole clips of the reference benchmark's ``train`` split (by default the benchmark's
  own). A clip's levels are read from the train items themselves (the TFA items' gold, then the ``ranks`` the
  builders record in ``meta`` for every video, filled in from other clips of the same object where those agree),
  so it works for every source (simulated, PhysiCLeAR, VTV-150K) without re-reading the source data, and the
  words are exactly the benchmark's vocabulary phrases. Clips whose levels stay incomplete are left out (counted).
- **Exclusion**: a video's neighbours never include clips of *any* of its item's objects. For train items this
  is cross-fitting (the gold of the asked object never reaches its own prompt); for val/test items it changes
  nothing, their objects are not in train.
- **Order**: highest cosine first, ties by clip id, so the output is a pure function of the inputs.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tacreasoner.jsonl import atomic_write_text
from tacreasoner.tasks.bench import BENCH_INFO, HELDOUT_SENSOR_SPLITS, load_bench
from tacreasoner.tasks.schema import ORDINALS, SPLITS, QAItem
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

if TYPE_CHECKING:
    from tacreasoner.train.data import VideoKey

__all__ = ["DEFAULT_K", "PREFIX", "REFERENCE_SPLIT", "ReferenceClip", "ReferenceSet", "RetrievalSummary",
           "augment_bench", "augment_items", "build_reference", "embed_videos", "load_encoder", "neighbour_text",
           "reference_clips", "reference_settings", "retrieval_bench"]

DEFAULT_K = 3
REFERENCE_SPLIT = "train"
PREFIX = "Closest clips felt before"
"""How every retrieval text starts (what tells an augmented question from a plain one)."""
FEATURE = "CLS token of the frozen appearance encoder, L2-normalised; cosine similarity"


@dataclass(frozen=True)
class ReferenceClip:
    """One labelled train clip neighbours are drawn from."""

    clip_id: str
    object_id: str
    name: str
    """The object as the items name it (``a sheet of aluminium foil``)."""
    levels: dict[str, int]
    """Attribute → rank 0..2, every attribute of the vocabulary, in its order."""
    key: VideoKey
    """(absolute video path, None, None): the whole clip."""

    def describe(self, vocab: dict[str, Attribute]) -> str:
        """``a sponge (soft; slightly rough; no bumps)``: name and level words in vocabulary order."""
        return f"{self.name} ({'; '.join(vocab[a].phrase(self.levels[a]) for a in vocab)})"


@dataclass
class ReferenceSet:
    """Reference clips (sorted by clip id) and their unit-length features (one row each)."""

    clips: list[ReferenceClip]
    features: np.ndarray
    vocabulary: str
    left_out: int = 0
    """Train clips without a complete set of levels (not used as neighbours)."""

    def neighbours(self, feature: np.ndarray, exclude_objects: Sequence[str], k: int) -> list[tuple[int, float]]:
        """(reference index, cosine) of the ``k`` nearest clips not of ``exclude_objects``; fewer if the set
        has fewer. Ties go to the smaller clip id (the clips are sorted by it, and the sort is stable)."""
        sims = self.features @ feature
        allowed = np.array([c.object_id not in exclude_objects for c in self.clips], dtype=bool)
        order = [int(i) for i in np.argsort(-sims, kind="stable") if allowed[i]]
        return [(i, float(sims[i])) for i in order[:k]]


@dataclass
class RetrievalSummary:
    out_dir: Path
    k: int
    reference_clips: int
    reference_objects: int
    items: dict[str, int]
    """split → items augmented."""
    notes: list[str] = field(default_factory=list)


# ------------------------------------------------------------------------------------------ encoder


def load_encoder(encoder_dir: str | os.PathLike[str]) -> tuple[Any, Any]:
    """The frozen appearance encoder of a ``pretrain-encoder`` or ``encoder get`` folder (or a Hugging Face VideoMAE
    one) and the video processing its inputs need (``video_processing.json`` when the folder has it, a VideoMAE's
    image processor normalisation, else the encoder's frame count and size with the defaults: what a model built on
    it uses, :func:`tacreasoner.model.build.appearance_video_settings`)."""
    from tacreasoner.model.appearance import CONFIG_NAME, load_appearance
    from tacreasoner.model.video_processing import VideoProcessingConfig
    from tacreasoner.model.videomae import is_videomae_dir, videomae_video_settings
    from tacreasoner.train.pretrain_encoder import VIDEO_CONFIG_NAME, video_config_for

    directory = Path(encoder_dir)
    if not (directory / CONFIG_NAME).is_file():
        raise FileNotFoundError(f"{directory}: not an appearance encoder folder (no {CONFIG_NAME}; give the output "
                                f"of `tacreasoner pretrain-encoder` or `tacreasoner encoder get`)")
    encoder = load_appearance(directory).eval()
    video = None
    if (directory / VIDEO_CONFIG_NAME).is_file():
        video = VideoProcessingConfig.from_dict(json.loads((directory / VIDEO_CONFIG_NAME).read_text()))
    elif is_videomae_dir(directory):
        video = VideoProcessingConfig(num_frames=encoder.config.num_frames, image_size=encoder.config.image_size,
                                      **videomae_video_settings(directory))
    return encoder, video_config_for(encoder.config, video)


def embed_videos(encoder: Any, video_config: Any, keys: Sequence[VideoKey], *, batch_size: int = 32,
                 video_cache: str | os.PathLike[str] | None = None, workers: int | None = None,
                 chunk: int = 512) -> dict[VideoKey, np.ndarray]:
    """Unit-length CLS features (float64) of each distinct video key. Videos are prepared by the training code's
    :class:`VideoBank` (same frames, same normalisation as the model sees), ``chunk`` at a time to bound memory;
    ``video_cache`` reuses (and fills) a training run's preprocessed-video folder."""
    import torch

    from tacreasoner.train.data import VideoBank

    unique = sorted(dict.fromkeys(keys), key=lambda k: (k[0], k[1] or 0, k[2] or 0))
    out: dict[VideoKey, np.ndarray] = {}
    param = next(encoder.parameters())
    for start in range(0, len(unique), chunk):
        part = unique[start:start + chunk]
        bank = VideoBank(video_config, ("unknown",))
        bank.build(part, cache_dir=video_cache, workers=workers)
        assert bank.pixels is not None
        with torch.no_grad():
            for i in range(0, len(part), batch_size):
                pixels = bank.pixels[i:i + batch_size].to(param.device, param.dtype)
                cls = encoder(pixels)[:, 0].double().cpu().numpy()
                cls /= np.maximum(np.linalg.norm(cls, axis=1, keepdims=True), 1e-12)
                out.update(zip(part[i:i + batch_size], cls, strict=True))
    return out


# ------------------------------------------------------------------------------------------ reference


def _merge(known: dict[str, int], new: dict[str, int], where: str) -> None:
    for attr, level in new.items():
        if known.setdefault(attr, level) != level:
            raise ValueError(f"{where}: {attr} is {level} here but {known[attr]} in another item")


def _item_levels(item: QAItem, vocab: dict[str, Attribute]) -> list[dict[str, int]]:
    """What ``item`` says about each of its videos' levels: the TFA gold, then the builders' ``meta["ranks"]``."""
    out: list[dict[str, int]] = [{} for _ in item.videos]
    where = f"item {item.id!r}"
    if item.task == "TFA-combined":
        _merge(out[0], {a: int(v) for a, v in item.gold.get("levels", {}).items() if a in vocab}, where)
    elif item.task.startswith("TFA-") and item.gold.get("attribute") in vocab:
        _merge(out[0], {item.gold["attribute"]: int(item.gold["level"])}, where)
    ranks, attr = item.meta.get("ranks"), item.meta.get("attribute")
    if isinstance(ranks, list) and len(ranks) == len(item.videos):
        for levels, rank in zip(out, ranks, strict=True):
            if isinstance(rank, dict):
                _merge(levels, {a: v for a, v in rank.items() if a in vocab and v in (0, 1, 2)}, where)
            elif attr in vocab and rank in (0, 1, 2) and not isinstance(rank, bool):
                _merge(levels, {attr: int(rank)}, where)
    return out


def reference_clips(items: Sequence[QAItem], video_root: Path, vocabulary: str) -> tuple[list[ReferenceClip], int]:
    """The whole clips of ``items`` (a train split) with every level of ``vocabulary`` known, sorted by clip id,
    and how many clips were left out for lacking one. Segments (OCSE) are not reference clips."""
    from tacreasoner.train.data import video_key

    vocab = get_vocabulary(vocabulary)
    levels: dict[VideoKey, dict[str, int]] = {}
    about: dict[VideoKey, tuple[str, str, str]] = {}  # key → (clip id, object, name)
    for item in items:
        names = item.meta.get("object_names")
        for i, (ref, levels_here) in enumerate(zip(item.videos, _item_levels(item, vocab), strict=True)):
            if ref.start is not None or ref.end is not None:
                continue
            key = video_key(ref, video_root, f"item {item.id!r}")
            obj = item.objects[i] if i < len(item.objects) else ref.clip_id
            name = names[i] if isinstance(names, list) and i < len(names) and isinstance(names[i], str) else \
                obj.replace("_", " ")
            about.setdefault(key, (ref.clip_id, obj, name))
            _merge(levels.setdefault(key, {}), levels_here, f"clip {ref.clip_id!r} (item {item.id!r})")
    # labels are per object in the datasets: a level one clip lacks is taken from its object's other clips when
    # those all agree
    per_object: dict[str, dict[str, set[int]]] = {}
    for key, known in levels.items():
        for attr, level in known.items():
            per_object.setdefault(about[key][1], {}).setdefault(attr, set()).add(level)
    clips, left_out = [], 0
    for key, known in levels.items():
        clip_id, obj, name = about[key]
        full = dict(known)
        for attr, values in per_object.get(obj, {}).items():
            if attr not in full and len(values) == 1:
                full[attr] = next(iter(values))
        if any(a not in full for a in vocab):
            left_out += 1
            continue
        clips.append(ReferenceClip(clip_id, obj, name, {a: full[a] for a in vocab}, key))
    clips.sort(key=lambda c: (c.clip_id, c.key))
    return clips, left_out


def build_reference(reference_bench: str | os.PathLike[str], encoder: Any, video_config: Any, *,
                    video_cache: str | os.PathLike[str] | None = None,
                    workers: int | None = None) -> ReferenceSet:
    """The labelled train clips of ``reference_bench`` with their features."""
    from tacreasoner.train.data import bench_video_root

    root = Path(reference_bench)
    if not (root / f"{REFERENCE_SPLIT}.jsonl").is_file():
        raise FileNotFoundError(f"{root}: no {REFERENCE_SPLIT} split to retrieve neighbours from (retrieval needs "
                                f"the training benchmark's labelled {REFERENCE_SPLIT} clips)")
    info, items = load_bench(root, REFERENCE_SPLIT)
    vocabulary = str(info.get("vocabulary") or (items[0].vocabulary if items else "vtv150k"))
    clips, left_out = reference_clips(items, bench_video_root(root, info), vocabulary)
    if not clips:
        raise ValueError(f"{root}: its {REFERENCE_SPLIT} split has no whole clip with all {vocabulary} levels known")
    feats = embed_videos(encoder, video_config, [c.key for c in clips], video_cache=video_cache, workers=workers)
    return ReferenceSet(clips, np.stack([feats[c.key] for c in clips]), vocabulary, left_out)


# ------------------------------------------------------------------------------------------ augmentation


def neighbour_text(per_video: Sequence[Sequence[ReferenceClip]], vocabulary: str) -> str:
    """The lines put before a question: one video → ``Closest clips felt before: a, b, c.``; several → a heading
    line and ``For the first video: a, b, c.`` per video."""
    vocab = get_vocabulary(vocabulary)
    lists = [", ".join(c.describe(vocab) for c in clips) for clips in per_video]
    if len(lists) == 1:
        return f"{PREFIX}: {lists[0]}."
    places = [ORDINALS[i] if i < len(ORDINALS) else f"video {i + 1}'s" for i in range(len(lists))]
    return "\n".join([f"{PREFIX}:", *(f"For the {p} video: {t}." for p, t in zip(places, lists, strict=True))])


def augment_items(items: Sequence[QAItem], video_root: Path, reference: ReferenceSet, encoder: Any,
                  video_config: Any, k: int = DEFAULT_K, *, video_cache: str | os.PathLike[str] | None = None,
                  workers: int | None = None) -> list[QAItem]:
    """Copies of ``items`` whose questions start with their videos' ``k`` nearest reference clips (never of the
    item's own objects); what was retrieved is in ``meta["retrieval"]``. Placeholders, ids, answers and gold are
    unchanged."""
    from tacreasoner.train.data import video_key

    if k < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    keys = {item.id: [video_key(v, video_root, f"item {item.id!r}") for v in item.videos] for item in items}
    # the reference clips are embedded already (a train split's items are mostly those clips): only the rest is
    feats = {clip.key: row for clip, row in zip(reference.clips, reference.features, strict=True)}
    feats.update(embed_videos(encoder, video_config, [key for ks in keys.values() for key in ks if key not in feats],
                              video_cache=video_cache, workers=workers))
    out = []
    for item in items:
        if item.vocabulary != reference.vocabulary:
            raise ValueError(f"item {item.id!r}: asks in the {item.vocabulary} vocabulary but the reference clips "
                             f"are labelled in {reference.vocabulary}")
        if item.question.startswith(PREFIX):
            raise ValueError(f"item {item.id!r}: already carries retrieved neighbours")
        found = [reference.neighbours(feats[key], item.objects, k) for key in keys[item.id]]
        if not all(found):
            raise ValueError(f"item {item.id!r}: no reference clip is left once its objects "
                             f"({', '.join(item.objects)}) are excluded; the {REFERENCE_SPLIT} split needs more "
                             f"objects")
        text = neighbour_text([[reference.clips[i] for i, _ in hits] for hits in found], reference.vocabulary)
        record = [[{"clip_id": reference.clips[i].clip_id, "object": reference.clips[i].object_id,
                    "similarity": round(sim, 6)} for i, sim in hits] for hits in found]
        new = dataclasses.replace(item, question=f"{text}\n{item.question}",
                                  meta={**item.meta, "retrieval": {"k": k, "videos": record}})
        new.validate()
        out.append(new)
    return out


def _bench_files(bench_dir: Path) -> list[tuple[str, Path]]:
    """(split name for :func:`load_bench`, file) of every split file a benchmark folder has."""
    named = [(s, bench_dir / f"{s}.jsonl") for s in (*SPLITS, *HELDOUT_SENSOR_SPLITS)]
    return [(s, p) for s, p in named if p.is_file()]


def _transform(bench_dir: Path, out_dir: Path, reference_bench: Path, encoder_dir: Path, k: int,
               video_cache: str | os.PathLike[str] | None, workers: int | None) -> RetrievalSummary:
    from tacreasoner.tasks.formats import write_jsonl
    from tacreasoner.train.data import bench_video_root

    if k < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    info_path = bench_dir / BENCH_INFO
    if not info_path.is_file():
        raise FileNotFoundError(f"{bench_dir}: not a benchmark directory (no {BENCH_INFO}; run "
                                f"`tacreasoner build-bench`)")
    info = json.loads(info_path.read_text())
    if info.get("retrieval"):
        raise ValueError(f"{bench_dir}: already retrieval-augmented (bench.json has 'retrieval'); give the plain "
                         f"benchmark")
    encoder, video_config = load_encoder(encoder_dir)  # before any video work: a wrong folder fails at once
    files = _bench_files(bench_dir)
    reference = build_reference(reference_bench, encoder, video_config, video_cache=video_cache, workers=workers)
    root = bench_video_root(bench_dir, info).resolve()
    augmented = {}
    for split, path in files:
        _, items = load_bench(bench_dir, split)
        augmented[path.name] = augment_items(items, root, reference, encoder, video_config, k,
                                             video_cache=video_cache, workers=workers)
    out_dir.mkdir(parents=True, exist_ok=True)
    for name, items in augmented.items():
        write_jsonl(items, out_dir / name)
    notes = [f"{reference.left_out} {REFERENCE_SPLIT} clips without every level known are not neighbours"] \
        if reference.left_out else []
    objects = len({c.object_id for c in reference.clips})
    info.update(video_root=str(root), notes=[*info.get("notes", []), *notes], retrieval={
        "encoder": str(encoder_dir.resolve()), "k": k, "reference_bench": str(reference_bench.resolve()),
        "reference_split": REFERENCE_SPLIT, "reference_clips": len(reference.clips),
        "reference_objects": objects, "feature": FEATURE,
        "excluded": "clips of the item's own objects"})
    atomic_write_text(out_dir / BENCH_INFO, json.dumps(info, indent=2))
    counts = {path.stem: len(augmented[path.name]) for _, path in files}
    return RetrievalSummary(out_dir, k, len(reference.clips), objects, counts, notes)


def retrieval_bench(bench_dir: str | os.PathLike[str], encoder_dir: str | os.PathLike[str],
                    out_dir: str | os.PathLike[str], k: int = DEFAULT_K, *,
                    reference_bench: str | os.PathLike[str] | None = None,
                    video_cache: str | os.PathLike[str] | None = None,
                    workers: int | None = None) -> RetrievalSummary:
    """Write ``out_dir``: ``bench_dir`` with every split's questions retrieval-augmented (neighbours from the
    ``train`` split of ``reference_bench``, by default ``bench_dir`` itself), ``bench.json`` recording how
    (``retrieval``) and an absolute ``video_root``, so the new folder works from any working directory."""
    bench, out = Path(bench_dir), Path(out_dir)
    if out.resolve() == bench.resolve():
        raise ValueError(f"{out}: the output must be a new folder, not the benchmark it is made from")
    return _transform(bench, out, Path(reference_bench) if reference_bench is not None else bench,
                      Path(encoder_dir), k, video_cache, workers)


def augment_bench(bench_dir: str | os.PathLike[str], reference_bench: str | os.PathLike[str],
                  encoder_dir: str | os.PathLike[str], k: int = DEFAULT_K, *,
                  video_cache: str | os.PathLike[str] | None = None, workers: int | None = None) -> RetrievalSummary:
    """Augment ``bench_dir`` in place with neighbours from ``reference_bench``'s ``train`` split: for a benchmark
    just built from a folder to score (``evaluate-physiclear --retrieval``), scored the way the training benchmark
    asked."""
    return _transform(Path(bench_dir), Path(bench_dir), Path(reference_bench), Path(encoder_dir), k, video_cache,
                      workers)


def reference_settings(bench: Path, encoder: Path | None, k: int | None) -> tuple[Path, int]:
    """The encoder and k to retrieve with against reference benchmark ``bench``: as given, else as ``bench``
    records them (a ``retrieval-bench`` output's bench.json), so a folder is asked the way the model was trained."""
    info_path = bench / BENCH_INFO
    if not info_path.is_file():
        raise FileNotFoundError(f"--retrieval {bench}: not a benchmark directory (no {BENCH_INFO})")
    recorded = json.loads(info_path.read_text(encoding="utf-8")).get("retrieval") or {}
    if encoder is None:
        if not recorded.get("encoder"):
            raise ValueError(f"--retrieval {bench} records no encoder (not made by `retrieval-bench`): give --encoder")
        encoder = Path(recorded["encoder"])
    if not (bench / "train.jsonl").is_file():
        raise FileNotFoundError(f"--retrieval {bench}: no train split to retrieve neighbours from")
    if not (encoder / "config.json").is_file():
        raise FileNotFoundError(f"--encoder {encoder}: not an appearance encoder folder (no config.json)")
    k = k if k is not None else int(recorded.get("k", DEFAULT_K))
    if k < 1:
        raise ValueError(f"--retrieval-k must be at least 1, got {k}")
    return encoder, k
