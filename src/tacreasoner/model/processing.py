"""``TacReasonerProcessor``: the tokenizer and the video preprocessing in one object, saved with the model.

It renders conversations with the tokenizer's chat template, expands each ``<tactile>`` into
``tokens_per_video`` placeholder ids, preprocesses the videos, and marks which tokens are the
question (steering the temporal branch) and which are the assistant's (the only ones with a loss). In the
question mask, 1 marks a question token and ``2 + k`` a token of the k-th option's name when the question lists
named options ("(A) kitchen sponge (B) fake apple …"), which the cross-video layer matches to the videos.
Token roles come from character offsets in the rendered text, so any chat template works as long
as rendering the prompt gives a prefix of rendering the whole conversation. What ends an assistant turn
(ChatML's ``<|im_end|>``, Llama-3's ``<|eot_id|>``, Gemma's ``<end_of_turn>``, Mistral's ``</s>``) is read from
the template itself, both for the labels (the model must learn to stop) and for ``eos_token_ids`` (generation
must stop there); templates that refuse a system role get the system text folded into the user turn.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from transformers import AutoTokenizer, BatchFeature, PreTrainedTokenizerBase

from tacreasoner.jsonl import atomic_write_text, read_json_object
from tacreasoner.model.encoder_config import DEFAULT_SENSOR_TYPES, TactileEncoderConfig
from tacreasoner.model.tokenizer import IM_END, TACTILE_PAD
from tacreasoner.model.video_processing import (
    VideoInput,
    VideoProcessingConfig,
    preprocess_video,
    sensor_index,
    sensor_of,
)
from tacreasoner.tasks.schema import PLACEHOLDER

__all__ = ["IGNORE_INDEX", "OPTION_MASK_OFFSET", "PROCESSOR_CONFIG_NAME", "TacReasonerProcessor", "option_spans",
           "record_answers", "record_gel_reference", "saved_processor_config"]

IGNORE_INDEX = -100
PROCESSOR_CONFIG_NAME = "processor_config.json"
OPTION_MASK_OFFSET = 2
"""``question_mask`` value of the tokens of the first listed option's name (the k-th's: this + k)."""

SYSTEM_FOLD_SEPARATOR = "\n\n"
"""Between the system text and the user's when a template without a system role gets them as one user turn."""
_PROBE_USER = "Probe question seven."
_PROBE_ANSWER = "Probe answer seven."
_PROBE_SYSTEM = "Probe system seven."

_OPTION_END = re.compile(r"[.?!;\n]")
_OPTION_TRAILER = re.compile(r"(?:[\s,:;]|\b(?:and|or)\b)+$", re.IGNORECASE)


def option_spans(text: str, marker: str | re.Pattern[str]) -> list[tuple[int, int]]:
    """Character spans of the names a question lists after ``marker`` (a regular expression whose first group is
    the option's one-letter label, e.g. ``\\(([A-Z])\\)`` for "(A) name (B) name …"; ``encoder.option_marker``):
    labels from the first letter on, consecutive, at least two; the last name ends at the sentence's end. [] when
    the question lists none. The format is the benchmark's, handed in by config."""
    pattern = re.compile(marker) if isinstance(marker, str) else marker
    run: list[re.Match[str]] = []
    for m in pattern.finditer(text):
        label = m.group(1) if pattern.groups else ""
        if len(label) == 1 and (ord(label) == ord(run[0].group(1)) + len(run) if run else label in "Aa1"):
            run.append(m)
        elif run:
            break
    if len(run) < 2:
        return []
    spans = []
    for i, m in enumerate(run):
        start = m.end()
        if i + 1 < len(run):
            end = run[i + 1].start()
        else:
            stop = _OPTION_END.search(text, start)
            end = stop.start() if stop else len(text)
        name = _OPTION_TRAILER.sub("", text[start:end])
        lead = len(name) - len(name.lstrip())
        if not name.strip():
            return []
        spans.append((start + lead, start + len(name)))
    return spans


def video_label(n: int) -> str:
    """What ``video_labels`` puts before the ``n``-th video (from 1): the name TouchCoT reasoning uses for it."""
    return f"Video {n}: "


def label_videos(text: str, fills: Sequence[str]) -> str:
    """Each placeholder → its label + ``fills[k]``; a label the question already gives is not repeated."""
    parts = text.split(PLACEHOLDER)
    if len(parts) - 1 != len(fills):
        raise ValueError(f"{len(parts) - 1} {PLACEHOLDER} placeholder(s) but {len(fills)} fill(s)")
    out = parts[0]
    for n, (fill, part) in enumerate(zip(fills, parts[1:], strict=True), start=1):
        label = video_label(n)
        out += ("" if out.endswith(label) else label) + fill + part
    return out


@dataclass
class _Encoded:
    input_ids: list[int]
    labels: list[int]
    question_mask: list[int]


class TacReasonerProcessor:
    """Tokenizer + video processing; ``prompt`` for inference, ``example``/``collate`` for training."""

    def __init__(self, tokenizer: PreTrainedTokenizerBase, video_config: VideoProcessingConfig | None = None, *,
                 tokens_per_video: int = 5, sensor_types: Sequence[str] = DEFAULT_SENSOR_TYPES,
                 system_prompt: str | None = None, video_labels: bool = False, option_marker: str = "",
                 vocabulary: str | None = None, answers: str | None = None) -> None:
        if tokens_per_video < 1:
            raise ValueError(f"tokens_per_video must be ≥ 1, got {tokens_per_video}")
        self.tokenizer = tokenizer
        self.video_config = video_config or VideoProcessingConfig()
        self.tokens_per_video = int(tokens_per_video)
        self.sensor_types = tuple(sensor_types)
        self.system_prompt = system_prompt
        self.video_labels = bool(video_labels)
        self.option_marker = option_marker or ""
        self.vocabulary = vocabulary
        """The answer vocabulary of the benchmark the model was trained on (its level words), recorded at saving:
        how ``ask``/``serve``/``demo`` read a clip stepwise unless told otherwise."""
        self.answers = answers
        """The answering mode its recipe recommends (``auto``, ``stepwise-vote``, …; chosen on val and recorded by the
        recipe: :func:`record_answers`): how ``ask``/``serve``/``demo`` answer unless told otherwise."""
        self._option_pattern = re.compile(self.option_marker) if self.option_marker else None
        self.tactile_token_id = self._single_token_id(TACTILE_PAD)
        if getattr(tokenizer, "chat_template", None) is None:
            raise ValueError("the tokenizer has no chat template: "
                             "run tacreasoner.model.tokenizer.prepare_tokenizer on it")
        self._template_facts: dict[tuple[Any, ...], Any] = {}

    @classmethod
    def for_encoder(cls, tokenizer: PreTrainedTokenizerBase, encoder: TactileEncoderConfig, **kwargs: Any,
                    ) -> TacReasonerProcessor:
        """A processor whose frames and token counts match ``encoder`` (the usual way to build one)."""
        video = VideoProcessingConfig(num_frames=encoder.num_frames, image_size=encoder.image_size,
                                      **kwargs.pop("video", {}))
        return cls(tokenizer, video, tokens_per_video=encoder.tokens_per_video, sensor_types=encoder.sensor_types,
                   video_labels=encoder.video_labels, option_marker=encoder.option_marker, **kwargs)

    def _single_token_id(self, token: str) -> int:
        ids = self.tokenizer.convert_tokens_to_ids([token])
        unk = self.tokenizer.unk_token_id
        if not ids or ids[0] is None or (unk is not None and ids[0] == unk):
            raise ValueError(f"the tokenizer has no {token!r} token: run tacreasoner.model.tokenizer.prepare_tokenizer "
                             f"on it and resize the model's embeddings")
        return int(ids[0])

    def _cached(self, name: str, compute: Callable[[], Any]) -> Any:
        """``compute()`` once per chat template and vocabulary: generation asks for these facts at every call,
        and a tokenizer changed after the processor was built (a new template, added tokens) is read again."""
        tok = self.tokenizer
        key = (name, str(getattr(tok, "chat_template", None)), len(tok), tok.eos_token_id)
        if key not in self._template_facts:
            self._template_facts[key] = compute()
        return self._template_facts[key]

    @property
    def eos_token_ids(self) -> list[int]:
        """Generation stops where the chat template ends an assistant turn (``<|im_end|>``, ``<|eot_id|>``,
        ``<end_of_turn>``, …) or at the tokenizer's eos; ``<|im_end|>`` also whenever the vocabulary has it."""
        return list(self._cached("eos", self._eos_token_ids))

    def _eos_token_ids(self) -> list[int]:
        ids = set(self._end_of_turn_ids())
        if IM_END in self.tokenizer.get_vocab():
            ids.add(self._single_token_id(IM_END))
        if self.tokenizer.eos_token_id is not None:
            ids.add(int(self.tokenizer.eos_token_id))
        return sorted(ids)

    def _end_of_turn_ids(self) -> list[int]:
        """The first special (or added) token the template renders after an assistant's content: its end-of-turn
        marker. Found by rendering a tiny user/assistant exchange; [] when the template renders none."""
        messages = [{"role": "user", "content": _PROBE_USER}, {"role": "assistant", "content": _PROBE_ANSWER}]
        try:
            text = self._render(messages, False)
        except ValueError:
            return []
        end = text.rfind(_PROBE_ANSWER)
        if end < 0:
            return []
        tail = text[end + len(_PROBE_ANSWER):]
        tok = self.tokenizer
        added = {int(i) for i in tok.get_added_vocab().values()} | {int(i) for i in tok.all_special_ids}
        added.discard(self.tactile_token_id)
        for token_id in tok(tail, add_special_tokens=False)["input_ids"]:
            if int(token_id) in added:
                return [int(token_id)]
        return []

    # ------------------------------------------------------------------ videos
    def preprocess_videos(self, videos: Sequence[VideoInput], *, seed: int | None = None) -> dict[str, torch.Tensor]:
        """pixel_values (V×T×3×H×W) and sensor_ids (V) for a list of clips/frames/paths."""
        arrays = [preprocess_video(v, self.video_config, seed=None if seed is None else seed + i)
                  for i, v in enumerate(videos)]
        c = self.video_config
        pixel_values = torch.from_numpy(np.stack(arrays)) if arrays else \
            torch.zeros((0, c.num_frames, 3, *c.image_size))
        sensor_ids = torch.tensor([sensor_index(sensor_of(v), self.sensor_types) for v in videos], dtype=torch.long)
        return {"pixel_values": pixel_values, "sensor_ids": sensor_ids}

    # ------------------------------------------------------------------ text
    def expand(self, text: str) -> str:
        """Each placeholder → its tactile tokens; with ``video_labels``, prompts holding several videos also
        say which is which ("Video 2: " before the second), the names the reasoning refers to them by."""
        pads = TACTILE_PAD * self.tokens_per_video
        n = text.count(PLACEHOLDER)
        if not self.video_labels or n < 2:
            return text.replace(PLACEHOLDER, pads)
        return label_videos(text, [pads] * n)

    def messages(self, question: str, answer: str | None = None, system: str | None = None) -> list[dict[str, str]]:
        out = []
        if system or self.system_prompt:
            out.append({"role": "system", "content": system or self.system_prompt})
        out.append({"role": "user", "content": question})
        if answer is not None:
            out.append({"role": "assistant", "content": answer})
        return out

    def _render(self, messages: list[dict[str, str]], add_generation_prompt: bool) -> str:
        """The chat template's text; a template that refuses the conversation is a ValueError saying so."""
        from jinja2.exceptions import TemplateError

        try:
            return self.tokenizer.apply_chat_template(messages, tokenize=False,
                                                      add_generation_prompt=add_generation_prompt)
        except TemplateError as exc:
            roles = ", ".join(str(m.get("role")) for m in messages)
            raise ValueError(f"the tokenizer's chat template cannot render this conversation (roles: {roles}): "
                             f"{exc}") from exc

    @property
    def template_takes_system(self) -> bool:
        """Whether the chat template renders a system turn; Gemma's, for one, raises on it instead."""
        return bool(self._cached("system", self._probe_system))

    def _probe_system(self) -> bool:
        system = [{"role": "system", "content": _PROBE_SYSTEM}, {"role": "user", "content": _PROBE_USER}]
        try:
            self._render(system, True)
        except ValueError:
            try:
                self._render(system[1:], True)
            except ValueError:
                return True  # the template fails for another reason: let the real conversation report it
            return False
        return True

    def _fold_system(self, messages: list[dict[str, str]]) -> tuple[list[dict[str, str]], list[int]]:
        """For templates without a system role: each system text goes in front of the next user turn's (joined
        by ``SYSTEM_FOLD_SEPARATOR``), as those models' own instructions suggest; also returns, per turn, how many
        leading characters were folded in (not question text). Unchanged when the template takes a system role."""
        if self.template_takes_system or all(m["role"] != "system" for m in messages):
            return messages, [0] * len(messages)
        out: list[dict[str, str]] = []
        skips: list[int] = []
        pending: list[str] = []
        for m in messages:
            if m["role"] == "system":
                if m["content"].strip():
                    pending.append(m["content"])
                continue
            if pending and m["role"] == "user":
                prefix = SYSTEM_FOLD_SEPARATOR.join(pending) + SYSTEM_FOLD_SEPARATOR
                out.append({**m, "content": prefix + m["content"]})
                skips.append(len(prefix))
                pending = []
            else:
                out.append(m)
                skips.append(0)
        if pending:
            raise ValueError("the tokenizer's chat template takes no system role, and no user turn follows the "
                             "system text to carry it")
        return out, skips

    def encode_conversation(self, messages: list[dict[str, str]], *, add_generation_prompt: bool) -> _Encoded:
        """Token ids with labels (assistant turns only) and the question mask (user text, no placeholders: 1, or
        ``OPTION_MASK_OFFSET + k`` on the name of the k-th option the last user turn lists).

        An assistant turn's labels cover its content and the end-of-turn marker the template renders right after
        it (whatever follows the content up to the end of the turn, trailing whitespace excepted), so the model
        learns to stop under any template. When the template refuses a system role (Gemma's raises), the system
        text is folded into the next user turn (``_fold_system``); it is then neither labelled nor question."""
        expanded = [{**m, "content": self.expand(m["content"])} for m in messages]
        expanded, skips = self._fold_system(expanded)
        text = self._render(expanded, add_generation_prompt)
        user_spans, assistant_spans, options = [], [], []
        previous = ""
        for i, (message, skip) in enumerate(zip(expanded, skips, strict=True)):
            upto = self._render(expanded[: i + 1], False)
            if not upto.startswith(previous) or not text.startswith(upto):
                raise ValueError("the tokenizer's chat template does not render a conversation's first turns as a "
                                 "prefix of the whole: token roles cannot be found")
            content = message["content"]
            start = upto.find(content, len(previous))
            if start < 0 and content.strip():  # templates that trim the content (Llama-3's, Gemma's)
                skip = max(0, skip - (len(content) - len(content.lstrip())))
                content = content.strip()
                start = upto.find(content, len(previous))
            if start < 0:
                raise ValueError(f"the chat template changed the content of the {message['role']} turn")
            span = (start + min(skip, len(content)), start + len(content))
            if message["role"] == "user":
                user_spans.append(span)
                question = text[span[0]:span[1]]
                listed = option_spans(question, self._option_pattern) if self._option_pattern else []
                options = [(span[0] + a, span[0] + b) for a, b in listed]
            elif message["role"] == "assistant":
                # what the template closes the turn with (<|im_end|>, <|eot_id|>, <end_of_turn>…) is part of what
                # the model must learn to produce; the newlines between turns are not
                assistant_spans.append((span[0], span[1] + len(upto[span[1]:].rstrip())))
            previous = upto
        enc = self.tokenizer(text, add_special_tokens=False, return_offsets_mapping=True)
        ids = list(enc["input_ids"])
        labels, question = [], []
        for tok, (a, b) in zip(ids, enc["offset_mapping"], strict=True):
            in_answer = any(s <= a and b <= e for s, e in assistant_spans)
            labels.append(tok if in_answer and tok != self.tactile_token_id else IGNORE_INDEX)
            in_question = any(s <= a and b <= e for s, e in user_spans) and tok != self.tactile_token_id
            option = next((k for k, (s, e) in enumerate(options) if a < e and b > s and text[a:b].strip()), None)
            question.append(OPTION_MASK_OFFSET + option if in_question and option is not None else int(in_question))
        return _Encoded(ids, labels, question)

    def _check_counts(self, texts: Sequence[str], videos: Sequence[Sequence[VideoInput]]) -> None:
        if len(texts) != len(videos):
            raise ValueError(f"{len(texts)} prompt(s) but {len(videos)} video list(s): give one list per prompt")
        for i, (text, vids) in enumerate(zip(texts, videos, strict=True)):
            n = text.count(PLACEHOLDER)
            if n != len(vids):
                raise ValueError(f"prompt {i} has {n} {PLACEHOLDER} placeholder(s) but {len(vids)} video(s) were "
                                 f"given; put one {PLACEHOLDER} in the question per video")
            if TACTILE_PAD in text:
                raise ValueError(f"prompt {i} contains the internal token {TACTILE_PAD!r}; write {PLACEHOLDER} instead")

    # ------------------------------------------------------------------ public entry points
    def example(self, question: str, answer: str, videos: Sequence[VideoInput], *, system: str | None = None,
                seed: int | None = None) -> dict[str, Any]:
        """One training example: ids, labels (assistant only), question mask, and its videos."""
        self._check_counts([question], [videos])
        enc = self.encode_conversation(self.messages(question, answer, system), add_generation_prompt=False)
        return {"input_ids": enc.input_ids, "labels": enc.labels, "question_mask": enc.question_mask,
                **self.preprocess_videos(videos, seed=seed)}

    def collate(self, examples: Sequence[dict[str, Any]], *, padding_side: str = "right") -> BatchFeature:
        """Pad examples into one batch; videos are concatenated in sample order (what the model expects)."""
        if not examples:
            raise ValueError("cannot collate an empty batch")
        width = max(len(e["input_ids"]) for e in examples)
        pad_id = self.tokenizer.pad_token_id if self.tokenizer.pad_token_id is not None else 0
        rows: dict[str, list[list[int]]] = {"input_ids": [], "attention_mask": [], "question_mask": [], "labels": []}
        for e in examples:
            n = len(e["input_ids"])
            fill = width - n

            def pad(seq: list[int], value: int, fill: int = fill) -> list[int]:
                return seq + [value] * fill if padding_side == "right" else [value] * fill + seq

            rows["input_ids"].append(pad(list(e["input_ids"]), pad_id))
            rows["attention_mask"].append(pad([1] * n, 0))
            rows["question_mask"].append(pad(list(e["question_mask"]), 0))
            rows["labels"].append(pad(list(e.get("labels") or [IGNORE_INDEX] * n), IGNORE_INDEX))
        batch = {k: torch.tensor(v, dtype=torch.long) for k, v in rows.items()}
        if all("labels" not in e for e in examples):
            del batch["labels"]
        batch["pixel_values"] = torch.cat([e["pixel_values"] for e in examples])
        batch["sensor_ids"] = torch.cat([e["sensor_ids"] for e in examples])
        return BatchFeature(batch)

    def prompt(self, question: str | Sequence[str], videos: Sequence[VideoInput] | Sequence[Sequence[VideoInput]],
               *, system: str | None = None) -> BatchFeature:
        """Inputs for ``generate``: one question (with its videos) or a batch of them, left-padded."""
        questions = [question] if isinstance(question, str) else list(question)
        video_lists = [list(videos)] if isinstance(question, str) else [list(v) for v in videos]
        self._check_counts(questions, video_lists)
        examples = []
        for q, vids in zip(questions, video_lists, strict=True):
            enc = self.encode_conversation(self.messages(q, None, system), add_generation_prompt=True)
            examples.append({"input_ids": enc.input_ids, "question_mask": enc.question_mask,
                             **self.preprocess_videos(vids)})
        return self.collate(examples, padding_side="left")

    def __call__(self, text: str | Sequence[str], videos: Sequence[VideoInput] | Sequence[Sequence[VideoInput]] = (),
                 ) -> BatchFeature:
        """Already-rendered text (``<tactile>`` placeholders kept) + videos → model inputs, no chat template."""
        texts = [text] if isinstance(text, str) else list(text)
        video_lists = [list(videos)] if isinstance(text, str) else [list(v) for v in videos]
        self._check_counts(texts, video_lists)
        examples = []
        for t, vids in zip(texts, video_lists, strict=True):
            ids = self.tokenizer(self.expand(t), add_special_tokens=False)["input_ids"]
            examples.append({"input_ids": ids, "question_mask": [int(i != self.tactile_token_id) for i in ids],
                             **self.preprocess_videos(vids)})
        return self.collate(examples, padding_side="left")

    # ------------------------------------------------------------------ save / load
    def to_dict(self) -> dict[str, Any]:
        return {"processor_class": type(self).__name__, "video": self.video_config.to_dict(),
                "tokens_per_video": self.tokens_per_video, "sensor_types": list(self.sensor_types),
                "system_prompt": self.system_prompt, "video_labels": self.video_labels,
                "option_marker": self.option_marker,
                **({"vocabulary": self.vocabulary} if self.vocabulary else {}),
                **({"answers": self.answers} if self.answers else {})}

    def save_pretrained(self, directory: str | os.PathLike[str], **kwargs: Any) -> None:
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        self.tokenizer.save_pretrained(directory)
        (directory / PROCESSOR_CONFIG_NAME).write_text(json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8")

    @classmethod
    def from_pretrained(cls, directory: str | os.PathLike[str], **kwargs: Any) -> TacReasonerProcessor:
        directory = Path(directory)
        path = directory / PROCESSOR_CONFIG_NAME
        data = read_json_object(path, "a processor config written by TacReasonerProcessor.save_pretrained")
        known = {"processor_class", "video", "tokens_per_video", "sensor_types", "system_prompt", "video_labels",
                 "option_marker", "vocabulary", "answers"}
        if unknown := sorted(set(data) - known):
            raise ValueError(f"{path}: unknown keys {unknown}; known: {', '.join(sorted(known))}")
        tokenizer = AutoTokenizer.from_pretrained(directory)
        return cls(tokenizer, VideoProcessingConfig.from_dict(data.get("video")),
                   tokens_per_video=int(data.get("tokens_per_video", 5)),
                   sensor_types=data.get("sensor_types", DEFAULT_SENSOR_TYPES), system_prompt=data.get("system_prompt"),
                   video_labels=bool(data.get("video_labels", False)),
                   option_marker=str(data.get("option_marker") or ""), vocabulary=data.get("vocabulary"),
                   answers=data.get("answers"))


def record_answers(model_dir: str | os.PathLike[str], answers: str) -> None:
    """Record in a saved model folder the answering mode its recipe recommends (``processor_config.json``'s
    ``answers``), so ``ask``/``serve``/``demo`` answer that way by default; the weights are untouched."""
    path, data = _read_processor_config(model_dir)
    _set_if_changed(path, data, "answers", answers)


GEL_KEYS = ("gel_reference", "gel_image", "gel_swap", "gel_swap_above")
"""``video`` keys :func:`record_gel_reference` owns: what a recipe measured on its train clips after training."""


def record_gel_reference(model_dir: str | os.PathLike[str], reference: dict[str, Any] | None,
                         swap: dict[str, Any] | None = None) -> None:
    """Record in a saved model folder the training sensor's gel at rest (``processor_config.json``'s
    ``video.gel_reference``; None removes it), so every clip it answers is colour-mapped to it; the weights are
    untouched; where training read its frames without the map (the gate's recipe), it is an answering-time
    preparation, and a model trained on mapped, swapped frames records the same map it trained with. ``swap``
    (``{image, swap_above}``, with a reference) also records the training clips' average gel at rest and the gate
    (``video.gel_image``, ``video.gel_swap_above``): a clip lit unlike every training clip (another sensor) has it
    swapped in; without ``swap_above`` every clip is; an optional ``mode`` is ``video.gel_swap``. None removes
    them."""
    path, data = _read_processor_config(model_dir)
    video = {k: v for k, v in dict(data.get("video") or {}).items() if k not in GEL_KEYS}
    if reference is not None:
        video["gel_reference"] = {k: [float(v) for v in reference[k]] for k in ("mean", "std")}
    if swap is not None:
        video["gel_image"] = swap["image"]
        if swap.get("swap_above") is not None:
            video["gel_swap_above"] = float(swap["swap_above"])
        if swap.get("mode", "whole") != "whole":
            video["gel_swap"] = swap["mode"]
    try:
        video = VideoProcessingConfig.from_dict(video).to_dict()
    except (TypeError, ValueError, KeyError) as exc:
        raise ValueError(f"{path}: cannot record gel_reference ({exc})") from None
    _set_if_changed(path, data, "video", video)


def saved_processor_config(model_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """A model folder's ``processor_config.json`` as saved, or {} where there is none or it cannot be read: for
    readers of what a folder records (its vocabulary, answering mode, colour map) that fall back to a default."""
    try:
        data = json.loads((Path(model_dir) / PROCESSOR_CONFIG_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _read_processor_config(model_dir: str | os.PathLike[str]) -> tuple[Path, dict[str, Any]]:
    path = Path(model_dir) / PROCESSOR_CONFIG_NAME
    return path, read_json_object(path, "a processor config written by TacReasonerProcessor.save_pretrained")


def _set_if_changed(path: Path, data: dict[str, Any], key: str, value: Any) -> None:
    """Rewrite a processor config with ``key`` set to ``value``, only where it differs (the file's time then says
    when the folder last changed)."""
    if data.get(key) != value:
        atomic_write_text(path, json.dumps({**data, key: value}, indent=2) + "\n")
