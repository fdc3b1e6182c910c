"""Benchmark directories: clips from a source → object-level splits → QA items per split, on disk.

A benchmark directory holds ``bench.json`` (source, settings, object → split, counts) and one
``<split>.jsonl`` of QA items per split. Splits are by *object*: no object appears in two splits
(checked before anything is written). TSA is zero-shot and never in ``train``.

DynTAC-Sim-Bench (``source="sim"``) is the project's stand-in for the paper's DynTAC-Bench, *not*
the paper's data: novel objects at test time, and one sensor style held out entirely for a second
test file (``test_heldout_sensor.jsonl``) and a val file (``val_heldout_sensor.jsonl``, to choose on).
"""

from __future__ import annotations

import dataclasses
import json
import re
from collections import Counter
from collections.abc import Collection, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from tacreasoner.data.clip import TactileClip
from tacreasoner.jsonl import atomic_write_text
from tacreasoner.tasks.schema import SPLITS, TFA_TASKS, QAItem
from tacreasoner.tasks.vocab import get_vocabulary

SOURCES = ("sim", "physiclear", "vtv150k")
BENCH_INFO = "bench.json"
HELDOUT_SENSOR_SPLITS = ("val_heldout_sensor", "test_heldout_sensor")
"""The held-out sensor style's val and test objects: ``<split>.jsonl`` in a benchmark folder beside the others."""
BENCH_VERSION = 2
"""2: TSA's letters balance within each question wording (in version 1 answering each of its three wordings with
one fixed letter scored 65% on the quickstart's val and test items; docs/benchmark.md). Other tasks are unchanged."""


def tasks_for(source: str, vocabulary: str, has_phases: bool, has_fruit: bool) -> list[str]:
    """The tasks a source supports: TFA for each attribute of its vocabulary, comparisons, and the
    dynamic tasks only where there are phases (OCSE) or real/fake fruit (RFOR). The PhysiCLeAR vocabulary also gets
    Octopi's three-way property comparison (PC), so its benchmarks hold Octopi's whole task set (docs/benchmark.md).
    ``source`` is kept for callers; what a benchmark asks depends on its vocabulary and its clips."""
    attrs = [f"TFA-{a}" for a in get_vocabulary(vocabulary)]
    comparisons = ["SFD", "PC"] if vocabulary == "physiclear" else ["SFD"]
    tasks = [t for t in TFA_TASKS if t in attrs] + ["TFA-combined", *comparisons, "SOI", "OSC", "TSA"]
    if has_fruit:
        tasks.append("RFOR")
    if has_phases:
        tasks.append("OCSE")
    return tasks


@dataclass
class BenchSummary:
    out_dir: Path
    source: str
    counts: dict[str, dict[str, int]]
    """split → task → number of items."""
    objects: dict[str, int]
    """split → number of objects."""
    notes: list[str] = field(default_factory=list)

    def table(self) -> str:
        tasks = sorted({t for c in self.counts.values() for t in c})
        splits = list(self.counts)
        lines = ["| task | " + " | ".join(splits) + " |", "|---|" + "---|" * len(splits)]
        for t in tasks:
            lines.append(f"| {t} | " + " | ".join(str(self.counts[s].get(t, 0)) for s in splits) + " |")
        lines.append("| objects | " + " | ".join(str(self.objects.get(s, 0)) for s in splits) + " |")
        return "\n".join(lines)


def load_source(source: str, data: Path, ranks: Path | None = None) -> tuple[list[TactileClip], list[str]]:
    """Clips of a source plus notes on what was skipped (never silently)."""
    from tacreasoner.data import readers

    if source == "sim":
        return readers.read_sim_dataset(data), []
    if source == "physiclear":
        clips = readers.read_physiclear(data)
        labelled = [c for c in clips if c.labels.get("physiclear")]
        notes = [f"{len(clips) - len(labelled)} unlabelled PhysiCLeAR clips left out (no property labels)"]
        return labelled, notes
    if source == "vtv150k":
        if ranks is None:
            raise ValueError("--source vtv150k needs --ranks (the per-object rank table, JSON or CSV)")
        clips = readers.read_vtv150k(data, ranks)
        labelled = [c for c in clips if c.labels.get("vtv150k")]
        return labelled, [f"{len(clips) - len(labelled)} VTV-150K clips without ranks left out"]
    raise ValueError(f"unknown source {source!r}; choose from {', '.join(SOURCES)}")


def _typical_of_name(clip: TactileClip) -> bool:
    """Whether a simulated object feels like its name suggests (OSC is only answerable for those).

    Procedural objects re-draw every parameter around a catalogue template but keep its name; an OSC
    question ("which clip is the sponge?") is only fair when hardness and elasticity match the
    template's. Real data and catalogue objects are typical by definition.
    """
    if clip.source != "sim":
        return True
    params = clip.meta.get("material_params") or {}
    if not params.get("procedural"):
        return True
    from tacreasoner.sim.materials import derive_labels, get_material

    template = derive_labels(get_material(re.sub(r"_\d+$", "", clip.object_id)))["vtv150k"]
    ranks = clip.labels.get("vtv150k") or {}
    return all(ranks.get(a) == template[a] for a in ("hardness", "elasticity"))


def _relative_paths(items: list[QAItem], root: Path) -> None:
    """Store video paths relative to the source root so a benchmark moves with its data."""
    root = root.resolve()
    for item in items:
        refs = []
        for ref in item.videos:
            # Readers give paths as they found them (relative to the working directory or absolute).
            path = Path(ref.path).resolve() if ref.path else None
            if path is not None and path.is_relative_to(root):
                ref = dataclasses.replace(ref, path=path.relative_to(root).as_posix())
            refs.append(ref)
        item.videos = refs


def _build_split(clips: Sequence[TactileClip], tasks: Sequence[str], vocabulary: str, split: str, seed: int,
                 per_task: int | None, source: str, notes: list[str]) -> list[QAItem]:
    from tacreasoner.tasks.builders import build_items_with_report

    items: list[QAItem] = []
    plain = [t for t in tasks if t != "OSC"]
    groups = [(plain, list(clips))]
    if "OSC" in tasks:
        groups.append((["OSC"], [c for c in clips if _typical_of_name(c)]))
    for group_tasks, group_clips in groups:
        if not group_tasks:
            continue
        built, report = build_items_with_report(group_clips, tasks=group_tasks, vocabulary=vocabulary, split=split,
                                                seed=seed, per_task=per_task, source=source)
        items += built
        notes += [f"{split}: {w}" for w in report.warnings]
    return items


def _assign_splits(clips: Sequence[TactileClip], seed: int, fractions: tuple[float, float, float],
                   train_objects: Collection[str] = ()) -> dict[str, str]:
    from tacreasoner.data.splits import object_level_split

    objects = sorted({c.object_id for c in clips})
    fixed = {c.object_id: c.split for c in clips if c.split in SPLITS}
    fixed.update({o: "train" for o in train_objects if o in objects})
    return object_level_split(objects, fractions=fractions, seed=seed, fixed=fixed)


def train_objects_of(bench_dir: str | Path) -> set[str]:
    """The objects another benchmark put in its train split: what a model trained on it has seen."""
    path = Path(bench_dir) / BENCH_INFO
    if not path.is_file():
        raise FileNotFoundError(f"{bench_dir}: not a benchmark directory (no {BENCH_INFO}; run `tacreasoner "
                                f"build-bench`)")
    splits = json.loads(path.read_text()).get("splits")
    if not isinstance(splits, dict):
        raise ValueError(f"{path}: field 'splits' should map each object to its split")
    return {str(obj) for obj, split in splits.items() if split == "train"}


def build_bench(source: str, data: str | Path, out_dir: str | Path, *, seed: int = 0, ranks: str | Path | None = None,
                heldout_sensor: str | None = None, per_task: int | None = None,
                fractions: tuple[float, float, float] = (0.7, 0.15, 0.15),
                vocabulary: str | None = None, train_objects: Collection[str] = ()) -> BenchSummary:
    """Write a benchmark directory; returns what was written (counts per split and task).

    ``vocabulary``: the answer phrases, by default the source's own (VTV-150K's for simulated clips). Simulated
    clips carry PhysiCLeAR's labels too, so ``source="sim", vocabulary="physiclear"`` asks them in PhysiCLeAR's
    words and tasks: the simulated data a real-data model trains on beside (or instead of) PhysiCLeAR.

    ``train_objects`` (e.g. ``train_objects_of`` a model's own benchmark) stay in train here: a second simulated
    corpus built to evaluate that model starts with the same named objects, and none it trained on may reach val or
    test. An object is matched by its id alone, so a procedural object that only shares a name is kept out too."""
    from tacreasoner.data.splits import check_no_leakage
    from tacreasoner.tasks.formats import write_jsonl

    data, out = Path(data), Path(out_dir)
    if source not in SOURCES:
        raise ValueError(f"unknown source {source!r}; choose from {', '.join(SOURCES)}")
    native = "physiclear" if source == "physiclear" else "vtv150k"
    if vocabulary is None:
        vocabulary = native
    elif vocabulary != native and not (source == "sim" and vocabulary == "physiclear"):
        raise ValueError(f"vocabulary {vocabulary!r} is not available for source {source!r} (it has {native!r} "
                         f"labels{'; simulated clips also have physiclear ones' if source == 'sim' else ''})")
    get_vocabulary(vocabulary)
    clips, notes = load_source(source, data, Path(ranks) if ranks else None)
    if not clips:
        raise ValueError(f"{data}: no labelled clips found for source {source!r}")
    sensors = sorted({c.sensor for c in clips})
    held = None
    if source == "sim":
        held = heldout_sensor if heldout_sensor is not None else (sensors[-1] if len(sensors) > 1 else None)
        if held is not None and held not in sensors:
            raise ValueError(f"--heldout-sensor {held!r} is not in the dataset (sensors: {', '.join(sensors)})")
        if held is None:
            notes.append("only one sensor style in the dataset: no held-out-sensor test file")
    main = [c for c in clips if c.sensor != held]
    split_of = _assign_splits(main, seed, fractions, train_objects)
    kept = sorted(set(train_objects) & set(split_of))
    if train_objects:
        notes.append(f"{len(kept)} object(s) kept in train because a model trained on them")
    check_no_leakage((split_of[c.object_id], c.object_id) for c in main)

    out.mkdir(parents=True, exist_ok=True)
    counts: dict[str, dict[str, int]] = {}
    objects: dict[str, int] = {}
    has_fruit = any(c.labels.get("real") is not None for c in clips)
    has_phases = any(c.phases for c in clips)
    all_tasks = tasks_for(source, vocabulary, has_phases, has_fruit)
    files: dict[str, list[QAItem]] = {}
    for split in SPLITS:
        split_clips = [c for c in main if split_of[c.object_id] == split]
        tasks = [t for t in all_tasks if not (split == "train" and t == "TSA")]
        objects[split] = len({c.object_id for c in split_clips})
        if not split_clips:
            notes.append(f"split {split!r} has no objects")
            files[split] = []
            continue
        files[split] = _build_split(split_clips, tasks, vocabulary, split, seed, per_task, source, notes)
    if held is not None:
        # The held-out style seen on val objects too (val_heldout_sensor: where a recipe for unseen sensors is
        # chosen) and on test objects (test_heldout_sensor: reported once, beside test).
        for offset, split in ((1, "test"), (2, "val")):
            split_objects = {o for o, s in split_of.items() if s == split}
            held_clips = [c for c in clips if c.sensor == held and c.object_id in split_objects]
            if not held_clips:
                continue
            items = _build_split(held_clips, all_tasks, vocabulary, split, seed + offset, per_task, source, notes)
            for item in items:
                item.id = f"{item.id}-{held}"
                item.meta["heldout_sensor"] = held
            files[f"{split}_heldout_sensor"] = items
            objects[f"{split}_heldout_sensor"] = len({c.object_id for c in held_clips})
    for name, items in files.items():
        _relative_paths(items, data)
        write_jsonl(items, out / f"{name}.jsonl")
        counts[name] = dict(sorted(Counter(i.task for i in items).items()))

    info = {
        "version": BENCH_VERSION,
        "source": source,
        "name": (("DynTAC-Sim-Bench (simulated; not the paper's DynTAC-Bench)" if vocabulary == "vtv150k" else
                  f"DynTAC-Sim clips in {vocabulary} vocabulary") if source == "sim" else source),
        "data": str(data.resolve()),
        "video_root": str(data.resolve()),
        "vocabulary": vocabulary,
        "seed": seed,
        "heldout_sensor": held,
        "sensors": sensors,
        "tasks": all_tasks,
        "splits": dict(sorted(split_of.items())),
        "fractions": list(fractions),
        "kept_in_train": kept,
        "counts": counts,
        "objects": objects,
        "notes": notes,
    }
    atomic_write_text(out / BENCH_INFO, json.dumps(info, indent=2))
    return BenchSummary(out, source, counts, objects, notes)


def build_folder_bench(data: str | Path, out_dir: str | Path, *, split: str | None = None, seed: int = 0,
                       per_task: int | None = None) -> tuple[BenchSummary, str]:
    """A benchmark of one split of a PhysiCLeAR-shaped folder (``labels.json`` + ``videos/``): the objects whose
    ``split`` is ``split`` (any name; default: ``val`` if present, else the only labelled split) become the
    benchmark's evaluation split, items built deterministically for ``seed``. Returns the summary and the
    benchmark's split name (``val``/``test`` as in the folder, ``test`` for any other name).

    Made for scoring a saved model on a copy nobody here has seen (Octopi's test objects): a listed video that is
    missing or unreadable is an error naming the file, never a silently smaller benchmark."""
    from tacreasoner.data import readers
    from tacreasoner.tasks.formats import write_jsonl

    data, out = Path(data), Path(out_dir)
    clips = [c for c in readers.read_physiclear(data, on_error="raise") if c.labels.get("physiclear")]
    labels = data / "labels.json" if data.is_dir() else data
    present = sorted({c.split for c in clips})
    if not present:
        raise ValueError(f"{labels}: no object with hardness/roughness/bumpiness labels")
    if split is None:  # val when there is one (no command reads test unless asked), else the only labelled split
        if "val" not in present and len(present) > 1:
            raise ValueError(f"{labels}: several labelled splits ({', '.join(present)}) and none is 'val': "
                             "choose one with --split")
        split = "val" if "val" in present else present[0]
    wanted = split.strip().lower()
    chosen = [c for c in clips if c.split == wanted]
    if not chosen:
        raise ValueError(f"{labels}: no labelled object has split {split!r}; splits present: {', '.join(present)}")
    name = wanted if wanted in ("val", "test") else "test"
    tasks = tasks_for("physiclear", "physiclear", has_phases=False, has_fruit=False)
    notes: list[str] = []
    items = _build_split(chosen, tasks, "physiclear", name, seed, per_task, "physiclear", notes)
    _relative_paths(items, data)
    out.mkdir(parents=True, exist_ok=True)
    write_jsonl(items, out / f"{name}.jsonl")
    counts = {name: dict(sorted(Counter(i.task for i in items).items()))}
    objects = {name: len({c.object_id for c in chosen})}
    info = {"version": BENCH_VERSION, "source": "physiclear", "name": f"PhysiCLeAR-shaped folder, split {wanted!r}",
            "data": str(data.resolve()), "video_root": str(data.resolve()), "vocabulary": "physiclear",
            "seed": seed, "folder_split": wanted, "heldout_sensor": None, "sensors": ["mini"], "tasks": tasks,
            "splits": {c.object_id: name for c in chosen}, "counts": counts, "objects": objects, "notes": notes}
    atomic_write_text(out / BENCH_INFO, json.dumps(info, indent=2))
    return BenchSummary(out, "physiclear", counts, objects, notes), name


def load_bench(bench_dir: str | Path, split: str = "test") -> tuple[dict, list[QAItem]]:
    """``bench.json`` and the items of one split (``val_heldout_sensor``/``test_heldout_sensor``: the held-out
    sensor's files)."""
    from tacreasoner.tasks.formats import read_jsonl

    root = Path(bench_dir)
    info_path = root / BENCH_INFO
    if not info_path.exists():
        raise FileNotFoundError(f"{root}: not a benchmark directory (no {BENCH_INFO}; run `tacreasoner build-bench`)")
    info = json.loads(info_path.read_text())
    path = root / f"{split}.jsonl"
    if not path.exists():
        available = sorted(p.stem for p in root.glob("*.jsonl"))
        raise FileNotFoundError(f"{path}: no such split; available: {', '.join(available)}")
    return info, read_jsonl(path)


def reword_bench(bench_dir: str | Path, out_dir: str | Path | None = None, *, wording: str = "heldout",
                 splits: Sequence[str] = ("val", "test")) -> dict[str, dict[str, int]]:
    """A benchmark whose ``splits`` hold their items asked in the ``wording`` set's wordings
    (``tasks.paraphrase``; held-out by default: words no training used), items without such a wording left out;
    written to ``out_dir`` (in place when None). Returns the items per split and task. Never writes a train split:
    a paraphrase benchmark is for evaluation only."""
    from tacreasoner.tasks.formats import write_jsonl
    from tacreasoner.tasks.paraphrase import reword_items

    src = Path(bench_dir)
    out = Path(out_dir) if out_dir is not None else src
    info = json.loads((src / BENCH_INFO).read_text()) if (src / BENCH_INFO).is_file() else None
    if info is None:
        raise FileNotFoundError(f"{src}: not a benchmark directory (no {BENCH_INFO}; run `tacreasoner build-bench`)")
    if "train" in splits:
        raise ValueError("reword_bench: the train split is never re-worded into an evaluation benchmark")
    counts: dict[str, dict[str, int]] = {}
    written: dict[str, list[QAItem]] = {}
    for split in splits:
        path = src / f"{split}.jsonl"
        if not path.is_file():
            continue
        _, items = load_bench(src, split)
        written[split] = reword_items(items, wording)
        counts[split] = dict(sorted(Counter(i.task for i in written[split]).items()))
    if not written:
        raise ValueError(f"{src}: none of the splits {', '.join(splits)} is there to re-word")
    out.mkdir(parents=True, exist_ok=True)
    for split, items in written.items():
        write_jsonl(items, out / f"{split}.jsonl")
    for stale in (p for p in out.glob("*.jsonl") if p.stem not in written and out != src):
        stale.unlink()
    info.update(wording=wording, counts=counts, name=f"{info.get('name', info.get('source'))}, {wording} wordings")
    atomic_write_text(out / BENCH_INFO, json.dumps(info, indent=2))
    return counts
