"""QA item files: our JSONL, VTV-LLM-style QA JSON (export and import), LLaVA-style conversations.

- **JSONL** (``write_jsonl`` / ``read_jsonl``): one ``QAItem.to_dict()`` per line, written atomically.
  Reading validates every line; a bad line raises ``ValueError("{path}:{lineno}: …")`` naming the
  problem (bad JSON, unknown or missing field, wrong type, placeholder/video count mismatch, unknown
  task, a gold answer text that does not follow the schema's conventions, a duplicate id).
- **VTV JSON**: the layout is modelled on the VTV-LLM / VideoLLaMA-style conversation JSON, a list of
  ``{"id", "video": [paths], "conversations": [{"from": "human", "value": "<video>\\n…"},
  {"from": "gpt", "value": answer}]}``. Each ``<tactile>`` placeholder becomes a ``<video>`` token in
  place; answer phrases are unchanged. Plain VTV JSON cannot carry our task and gold, so the export
  stores the full item under the extra key ``"tacreasoner"`` and a round trip through our own
  export is lossless (OCSE segments too: a plain VTV consumer would see the whole clip). For foreign
  files without that key, only TFA tasks can be recovered, from the answer phrase (a level phrase of
  the vocabulary, possibly inside a sentence, or ``attribute: phrase; …``); anything else raises a
  ``ValueError`` naming the record.
- **LLaVA JSON** (``to_llava``): ``{"id", "videos", "conversations"}`` with the answer wrapped in
  ``<answer>…</answer>``; ``read_llava`` imports it back with the same rules as VTV JSON.

``video_root``: on export, relative video paths are joined onto it (absolute ones are kept); on
import, paths under it are made relative to it. A video without a path is written as its clip id.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from tacreasoner.jsonl import atomic_write_text, iter_jsonl
from tacreasoner.tasks.answers import render_answer
from tacreasoner.tasks.schema import PLACEHOLDER, QAItem, VideoRef
from tacreasoner.tasks.vocab import get_vocabulary

VIDEO_TOKEN = "<video>"
EXTRA_KEY = "tacreasoner"
"""Extra key of an exported VTV/LLaVA record holding our full item (task, gold, segments, meta)."""

_ITEM_TYPES: dict[str, type | tuple[type, ...]] = {
    "id": str, "task": str, "question": str, "answer": str, "gold": dict, "videos": list, "objects": list,
    "vocabulary": str, "options": list, "split": str, "source": str, "meta": dict,
}
_REQUIRED = ("id", "task", "question", "answer", "gold", "videos", "objects")
_VIDEO_TYPES: dict[str, tuple[type, ...]] = {
    "clip_id": (str,), "path": (str, type(None)), "start": (int, type(None)), "end": (int, type(None)),
}
_HUMAN = ("human", "user")
_ASSISTANT = ("gpt", "assistant")
_ANSWER_TAG = re.compile(r"<answer>(.*?)</answer>", re.DOTALL)
_THINK_TAG = re.compile(r"<think>.*?</think>", re.DOTALL)


# ------------------------------------------------------------------------------------------ helpers


def _type_name(t: type | tuple[type, ...]) -> str:
    types = t if isinstance(t, tuple) else (t,)
    return " or ".join("null" if x is type(None) else x.__name__ for x in types)


def _check_video(i: int, v: object) -> None:
    if not isinstance(v, dict):
        raise ValueError(f"videos[{i}] must be an object with clip_id/path/start/end, got {type(v).__name__}")
    unknown = set(v) - set(_VIDEO_TYPES)
    if unknown:
        raise ValueError(f"videos[{i}]: unknown field(s) {sorted(unknown)}")
    if "clip_id" not in v:
        raise ValueError(f"videos[{i}]: missing field 'clip_id'")
    for name, types in _VIDEO_TYPES.items():
        value = v.get(name)
        if name in v and (not isinstance(value, types) or isinstance(value, bool)):
            raise ValueError(f"videos[{i}].{name} must be {_type_name(types)}, got {value!r}")


def check_answer(item: QAItem) -> None:
    """ValueError unless the item's answer text is exactly what its gold renders to."""
    expected = render_answer(item.task, item.gold, item.vocabulary)
    if item.answer != expected:
        raise ValueError(f"item {item.id!r}: answer {item.answer!r} does not match its gold {item.gold!r} "
                         f"(expected {expected!r})")


def parse_item(data: object, *, check_answers: bool = True) -> QAItem:
    """A validated ``QAItem`` from a JSON object; ValueError naming the problem."""
    if not isinstance(data, dict):
        raise ValueError(f"expected a JSON object, got {type(data).__name__}")
    unknown = set(data) - set(_ITEM_TYPES)
    if unknown:
        raise ValueError(f"unknown field(s) {sorted(unknown)}")
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        raise ValueError(f"missing field(s) {missing}")
    for name, t in _ITEM_TYPES.items():
        if name in data and not isinstance(data[name], t):
            raise ValueError(f"field {name!r} must be {_type_name(t)}, got {type(data[name]).__name__}")
    for i, v in enumerate(data["videos"]):
        _check_video(i, v)
    for key in ("objects", "options"):
        if not all(isinstance(x, str) for x in data.get(key, [])):
            raise ValueError(f"field {key!r} must be a list of strings")
    get_vocabulary(data.get("vocabulary", "vtv150k"))
    item = QAItem.from_dict(data)
    if check_answers:
        check_answer(item)
    return item


# ------------------------------------------------------------------------------------------ JSONL


def write_jsonl(items: Iterable[QAItem], path: str | Path) -> Path:
    """One item per line (UTF-8), written atomically."""
    return atomic_write_text(path, "".join(item.to_json() + "\n" for item in items))


def read_jsonl(path: str | Path, *, check_answers: bool = True) -> list[QAItem]:
    """Validated items; any bad line raises ``ValueError("{path}:{lineno}: …")``. Blank lines are skipped."""
    path = Path(path)
    items: list[QAItem] = []
    first_line: dict[str, int] = {}
    for lineno, data in iter_jsonl(path):
        try:
            item = parse_item(data, check_answers=check_answers)
        except (ValueError, TypeError) as e:
            raise ValueError(f"{path}:{lineno}: {e}") from None
        if item.id in first_line:
            first = first_line[item.id]
            raise ValueError(f"{path}:{lineno}: duplicate item id {item.id!r} (first on line {first})")
        first_line[item.id] = lineno
        items.append(item)
    return items


# ------------------------------------------------------------------------------------------ conversations


def to_video_tokens(question: str) -> str:
    """``<tactile>`` → ``<video>``, in place."""
    if VIDEO_TOKEN in question:
        raise ValueError(f"question already contains {VIDEO_TOKEN!r}: {question!r}")
    return question.replace(PLACEHOLDER, VIDEO_TOKEN)


def from_video_tokens(value: str) -> str:
    """``<video>`` → ``<tactile>``, in place."""
    return value.replace(VIDEO_TOKEN, PLACEHOLDER)


def _export_path(ref: VideoRef, video_root: str | Path | None) -> str:
    p = ref.path if ref.path is not None else ref.clip_id
    if video_root is not None and not Path(p).is_absolute():
        return (Path(video_root) / p).as_posix()
    return p


def _import_path(p: str, video_root: str | Path | None) -> str:
    if video_root is not None:
        try:
            return Path(p).relative_to(video_root).as_posix()
        except ValueError:
            pass
    return p


def _record(item: QAItem, videos_key: str, answer: str, video_root: str | Path | None, include_meta: bool) -> dict:
    record: dict[str, Any] = {
        "id": item.id,
        videos_key: [_export_path(v, video_root) for v in item.videos],
        "conversations": [{"from": "human", "value": to_video_tokens(item.question)},
                          {"from": "gpt", "value": answer}],
    }
    if include_meta:
        record[EXTRA_KEY] = item.to_dict()
    return record


def to_vtv_json(items: Iterable[QAItem], video_root: str | Path | None = None, *,
                include_meta: bool = True) -> list[dict]:
    """VTV-LLM-style QA records; ``include_meta`` keeps our item under ``"tacreasoner"`` (lossless)."""
    return [_record(item, "video", item.answer, video_root, include_meta) for item in items]


def to_llava(items: Iterable[QAItem], video_root: str | Path | None = None, *,
             include_meta: bool = False) -> list[dict]:
    """LLaVA-style records with the gold wrapped as ``<answer>…</answer>``."""
    return [_record(item, "videos", f"<answer>{item.answer}</answer>", video_root, include_meta) for item in items]


def _write_json(records: list[dict], path: str | Path) -> Path:
    return atomic_write_text(path, json.dumps(records, ensure_ascii=False, indent=2) + "\n")


def write_vtv_json(items: Iterable[QAItem], path: str | Path, video_root: str | Path | None = None, *,
                   include_meta: bool = True) -> Path:
    return _write_json(to_vtv_json(items, video_root, include_meta=include_meta), path)


def write_llava(items: Iterable[QAItem], path: str | Path, video_root: str | Path | None = None, *,
                include_meta: bool = False) -> Path:
    return _write_json(to_llava(items, video_root, include_meta=include_meta), path)


# ------------------------------------------------------------------------------------------ import


def strip_answer(value: str) -> str:
    """The final answer of an assistant turn: the ``<answer>`` content if tagged, minus any ``<think>``."""
    tagged = _ANSWER_TAG.search(value)
    return (tagged.group(1) if tagged else _THINK_TAG.sub("", value)).strip()


def _phrase_hits(text: str, vocabulary: str) -> set[tuple[str, int]]:
    """(attribute, level) of every level phrase in ``text`` not contained in a longer match."""
    spans = []
    for name, attr in get_vocabulary(vocabulary).items():
        for level, phrase in enumerate(attr.levels):
            for m in re.finditer(rf"\b{re.escape(phrase)}\b", text):
                spans.append((m.start(), m.end(), name, level))
    kept = [s for s in spans if not any(o[0] <= s[0] and s[1] <= o[1] and o[1] - o[0] > s[1] - s[0] for o in spans)]
    return {(name, level) for _, _, name, level in kept}


def infer_tfa_gold(answer: str, vocabulary: str = "vtv150k") -> tuple[str, dict] | None:
    """``(task, gold)`` for a TFA answer phrase (alone, in a sentence, or combined), else None."""
    vocab = get_vocabulary(vocabulary)
    text = " ".join(answer.lower().split()).rstrip(".")
    parts = [p.split(":", 1) for p in text.split(";")]
    if len(parts) > 1 and all(len(p) == 2 for p in parts):
        levels = {}
        for name, phrase in ((n.strip(), ph.strip()) for n, ph in parts):
            if name in vocab and phrase in vocab[name].levels:
                levels[name] = vocab[name].levels.index(phrase)
        if set(levels) == set(vocab) and len(parts) == len(vocab):
            return "TFA-combined", {"levels": {a: levels[a] for a in vocab}}
    hits = _phrase_hits(text, vocabulary)
    if len(hits) == 1:
        name, level = hits.pop()
        return f"TFA-{name}", {"attribute": name, "level": level}
    return None


def _turns(record: Mapping, where: str) -> tuple[str, str]:
    conversations = record.get("conversations")
    if not isinstance(conversations, list):
        raise ValueError(f"{where}: missing 'conversations' list")
    human = next((t for t in conversations if isinstance(t, dict) and t.get("from") in _HUMAN), None)
    reply = next((t for t in conversations if isinstance(t, dict) and t.get("from") in _ASSISTANT), None)
    if human is None or reply is None:
        raise ValueError(f"{where}: needs a human turn and a gpt/assistant turn")
    if not isinstance(human.get("value"), str) or not isinstance(reply.get("value"), str):
        raise ValueError(f"{where}: conversation values must be strings")
    return human["value"], reply["value"]


def _own_item(record: Mapping, question: str, answer: str, where: str) -> QAItem:
    try:
        item = parse_item(record[EXTRA_KEY])
    except (ValueError, TypeError) as e:
        raise ValueError(f"{where}: bad {EXTRA_KEY!r} item: {e}") from None
    if item.question != question or item.answer != answer:
        raise ValueError(f"{where}: conversation differs from the stored {EXTRA_KEY!r} item (edited after export?)")
    return item


def _clip_id(path: str) -> str:
    return Path(path).with_suffix("").as_posix()


def _object_of(path: str) -> str:
    """VTV-150K names videos ``<object>_<k>.mp4``; elsewhere the file stem stands for the object."""
    stem = Path(path).stem
    head, _, tail = stem.rpartition("_")
    return head if head and tail.isdigit() else stem


def _foreign_item(record: Mapping, i: int, question: str, answer: str, where: str, *, vocabulary: str, source: str,
                  split: str, video_root: str | Path | None) -> QAItem:
    videos = record.get("video", record.get("videos"))
    videos = [videos] if isinstance(videos, str) else videos
    if not isinstance(videos, list) or not videos or not all(isinstance(v, str) for v in videos):
        raise ValueError(f"{where}: 'video' must be a path or a non-empty list of paths")
    if question.count(PLACEHOLDER) != len(videos):
        raise ValueError(f"{where}: {question.count(PLACEHOLDER)} {VIDEO_TOKEN} token(s) for {len(videos)} video(s)")
    inferred = infer_tfa_gold(answer, vocabulary)
    if inferred is None:
        raise ValueError(f"{where}: cannot infer the task from answer {answer!r}; plain VTV JSON only identifies "
                         f"TFA answers ({vocabulary} level phrases); export with tacreasoner to keep task and gold")
    task, gold = inferred
    paths = [_import_path(v, video_root) for v in videos]
    canonical = render_answer(task, gold, vocabulary)
    meta = {"imported_from": "conversation json"} | ({"raw_answer": answer} if answer != canonical else {})
    return QAItem(id=str(record.get("id", f"record-{i:05d}")), task=task, question=question, answer=canonical,
                  gold=gold, videos=[VideoRef(_clip_id(p), p) for p in paths], objects=[_object_of(p) for p in paths],
                  vocabulary=vocabulary, split=split, source=source, meta=meta)


def from_conversations(records: Sequence[Any], *, vocabulary: str = "vtv150k", source: str = "", split: str = "",
                       video_root: str | Path | None = None, where: str = "records") -> list[QAItem]:
    """Items from VTV- or LLaVA-style records (ours round-trip exactly; foreign ones: TFA only)."""
    items = []
    for i, record in enumerate(records):
        rid = record.get("id") if isinstance(record, dict) else None
        at = f"{where}: record {i}" + (f" (id {rid!r})" if rid is not None else "")
        if not isinstance(record, dict):
            raise ValueError(f"{at}: expected an object, got {type(record).__name__}")
        human, reply = _turns(record, at)
        question, answer = from_video_tokens(human), strip_answer(reply)
        if EXTRA_KEY in record:
            items.append(_own_item(record, question, answer, at))
        else:
            items.append(_foreign_item(record, i, question, answer, at, vocabulary=vocabulary, source=source,
                                       split=split, video_root=video_root))
    return items


def _read_json_list(path: str | Path) -> list:
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}:{e.lineno}: bad JSON: {e.msg} (column {e.colno})") from None
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a JSON list of records, got {type(data).__name__}")
    return data


def read_vtv_json(path: str | Path, *, vocabulary: str = "vtv150k", source: str = "vtv150k", split: str = "",
                  video_root: str | Path | None = None) -> list[QAItem]:
    """Items from a VTV-LLM-style QA JSON file (see the module docstring for what can be recovered)."""
    return from_conversations(_read_json_list(path), vocabulary=vocabulary, source=source, split=split,
                              video_root=video_root, where=str(path))


def read_llava(path: str | Path, *, vocabulary: str = "vtv150k", source: str = "", split: str = "",
               video_root: str | Path | None = None) -> list[QAItem]:
    """Items from a LLaVA-style conversation file (``<answer>`` tags stripped)."""
    return from_conversations(_read_json_list(path), vocabulary=vocabulary, source=source, split=split,
                              video_root=video_root, where=str(path))
