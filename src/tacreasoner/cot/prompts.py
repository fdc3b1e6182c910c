"""Teacher prompts for TouchCoT (paper §3.1 step 2): templates are data, this module fills them.

``prompts/_common.yaml`` holds the shared system and user templates, the cue-table lines and the
per-attribute hints; one file per task family (``tfa.yaml``, ``sfd.yaml``, …) adds its guidance and
answer rule and may override the shared parts. Every file is validated when loaded (allowed keys,
allowed and required slots, task coverage) and errors name ``file:line`` and the field.

The paper's teacher is told the gold answer and asked to justify it (``reveal_answer=True``, the
default); with ``reveal_answer=False`` it must work the answer out (for measuring a teacher).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from tacreasoner.cot import cuetext
from tacreasoner.cot.schema import STAGES, CoTJob, Prompt, VideoCues
from tacreasoner.tasks.answers import COMBINED_SEP
from tacreasoner.tasks.schema import CONTACT_STATES, ORDINALS, PC_RELATIONS, PLACEHOLDER, TASKS, QAItem
from tacreasoner.tasks.vocab import get_vocabulary
from tacreasoner.yamlfile import read_yaml

__all__ = [
    "PROMPT_DIR",
    "PROMPT_VERSION",
    "PromptSet",
    "PromptTemplateError",
    "build_prompt",
    "load_prompts",
    "prompt_version",
    "render_cue_tables",
]

PROMPT_VERSION = "touchcot-v1"
"""Version of the packaged template set; recorded with every sample (part of the job's cache key)."""
BLIND_SUFFIX = "+blind"
PROMPT_DIR = Path(__file__).parent / "prompts"
COMMON_FILE = "_common.yaml"
PROMPT_TASKS = tuple(t for t in TASKS if t != "TSA")
"""Tasks that need a prompt: all but TSA (zero-shot, never in TouchCoT)."""

# Field → (allowed slots, required slots).
_GUIDANCE = frozenset({"attribute", "attributes", "hint", "hints", "superlative", "comparative", "n_videos"})
_RULE = frozenset({"choices", "answer_format", "options", "n_videos"})
TEXT_FIELDS: dict[str, tuple[frozenset[str], frozenset[str]]] = {
    "system": (frozenset({"guidance", "answer_rule"}), frozenset({"answer_rule"})),
    "user": (frozenset({"question", "cue_tables", "stages_block", "answer_block", "n_videos"}),
             frozenset({"question", "cue_tables", "answer_block"})),
    "stages_block": (frozenset({"stages"}), frozenset()),
    "reveal": (frozenset({"answer"}), frozenset({"answer"})),
    "blind": (frozenset(), frozenset()),
    "guidance": (_GUIDANCE, frozenset()),
    "answer_rule": (_RULE, frozenset()),
}
COMMON_KEYS = frozenset({"version", "system", "user", "stages_block", "reveal", "blind", "cue_table", "hints"})
FAMILY_KEYS = frozenset({"family", "tasks", "guidance", "answer_rule", "system", "user", "stages_block"})
CUE_TABLE_KEYS = frozenset({"header", *STAGES, "surface", "segment_header", "segment", "no_contact"})
RULE_VARIANTS: dict[str, tuple[str, ...]] = {"SFD": ("which", "yesno")}
"""Tasks whose answer rule depends on the item (SFD: gold ``kind``): one rule per variant."""


class PromptTemplateError(ValueError):
    """A prompt file breaks the rules; the message names the file, line and field."""


@dataclass(frozen=True)
class Family:
    name: str
    tasks: tuple[str, ...]
    fields: Mapping[str, Any]
    """guidance, answer_rule (str, or variant → str) and any overridden shared fields."""
    file: str
    lines: Mapping[str, int] = field(default_factory=dict)

    def where(self, key: str) -> str:
        return f"{self.file}:{self.lines.get(key, 1)}: field {key!r}"


@dataclass(frozen=True)
class PromptSet:
    """A validated template set: the shared parts plus one family per task."""

    version: str
    common: Mapping[str, Any]
    families: Mapping[str, Family]
    """task → its family."""
    file: str
    lines: Mapping[str, int] = field(default_factory=dict)

    def where(self, key: str) -> str:
        return f"{self.file}:{self.lines.get(key, 1)}: field {key!r}"

    def text(self, task: str, key: str) -> tuple[str, str]:
        """(template, where) of a shared field, taking the family's override when it has one."""
        fam = self.family(task)
        if key in fam.fields:
            return fam.fields[key], fam.where(key)
        return self.common[key], self.where(key)

    def family(self, task: str) -> Family:
        if task == "TSA":
            raise ValueError("TSA is zero-shot: it has no TouchCoT prompt and must never get training data")
        try:
            return self.families[task]
        except KeyError:
            raise ValueError(f"no prompt family covers task {task!r} in {Path(self.file).parent}") from None


# ------------------------------------------------------------------------------------------- loading


def _read(path: Path) -> tuple[dict, dict[str, int]]:
    """The top-level mapping of a YAML file and the line of every key (nested keys dotted: ``a.b``)."""
    data, lines = read_yaml(path, PromptTemplateError)
    if not isinstance(data, dict):
        raise PromptTemplateError(f"{path}:1: top level must be a mapping of fields")
    return data, {".".join(str(k) for k in at): line for at, line in lines.items() if at}


def _check_text(value: object, where: str, allowed: frozenset[str], required: frozenset[str]) -> str:
    if not isinstance(value, str) or not value.strip():
        raise PromptTemplateError(f"{where}: must be a non-empty string")
    try:
        unknown, missing = cuetext.slot_problems(value, allowed, required)
    except ValueError as e:
        raise PromptTemplateError(f"{where}: malformed template ({e}); write literal braces as {{{{ }}}}") from None
    if unknown:
        raise PromptTemplateError(f"{where}: unknown slot(s) {', '.join('{' + s + '}' for s in unknown)}; "
                                  f"allowed: {', '.join(sorted(allowed)) or 'none'}")
    if missing:
        raise PromptTemplateError(f"{where}: must contain slot(s) {', '.join('{' + s + '}' for s in missing)}")
    return value


def _check_keys(data: Mapping, allowed: frozenset[str], required: frozenset[str], path: Path,
                lines: Mapping[str, int], prefix: str = "") -> None:
    unknown = sorted(set(data) - allowed)
    if unknown:
        first = unknown[0]
        raise PromptTemplateError(f"{path}:{lines.get(prefix + str(first), 1)}: unknown field(s) {unknown}; "
                                  f"allowed: {sorted(allowed)}")
    missing = sorted(required - set(data))
    if missing:
        at = lines.get(prefix.rstrip("."), 1) if prefix else 1
        raise PromptTemplateError(f"{path}:{at}: missing field(s) {missing}")


def _where(path: Path, lines: Mapping[str, int], key: str) -> str:
    return f"{path}:{lines.get(key, 1)}: field {key!r}"


def _load_common(path: Path) -> tuple[dict, dict[str, int]]:
    data, lines = _read(path)
    _check_keys(data, COMMON_KEYS, COMMON_KEYS, path, lines)
    if not isinstance(data["version"], str) or not data["version"].strip():
        raise PromptTemplateError(f"{_where(path, lines, 'version')}: must be a non-empty string")
    for key in ("system", "user", "stages_block", "reveal", "blind"):
        _check_text(data[key], _where(path, lines, key), *TEXT_FIELDS[key])
    table = data["cue_table"]
    if not isinstance(table, dict):
        raise PromptTemplateError(f"{_where(path, lines, 'cue_table')}: must map line names to templates")
    _check_keys(table, CUE_TABLE_KEYS, CUE_TABLE_KEYS, path, lines, "cue_table.")
    for key, text in table.items():
        _check_text(text, _where(path, lines, f"cue_table.{key}"), cuetext.SLOTS, frozenset())
    hints = data["hints"]
    attributes = {a for vocab in ("vtv150k", "physiclear") for a in get_vocabulary(vocab)}
    if not isinstance(hints, dict):
        raise PromptTemplateError(f"{_where(path, lines, 'hints')}: must map attributes to hint sentences")
    _check_keys(hints, frozenset(attributes), frozenset(attributes), path, lines, "hints.")
    for key, text in hints.items():
        _check_text(text, _where(path, lines, f"hints.{key}"), frozenset(), frozenset())
    return data, lines


def _load_family(path: Path) -> Family:
    data, lines = _read(path)
    _check_keys(data, FAMILY_KEYS, frozenset({"family", "tasks", "guidance", "answer_rule"}), path, lines)
    name = data["family"]
    if not isinstance(name, str) or not name.strip():
        raise PromptTemplateError(f"{_where(path, lines, 'family')}: must be a non-empty string")
    tasks = data["tasks"]
    if not isinstance(tasks, list) or not tasks or not all(isinstance(t, str) for t in tasks):
        raise PromptTemplateError(f"{_where(path, lines, 'tasks')}: must be a non-empty list of task names")
    for t in tasks:
        if t == "TSA":
            raise PromptTemplateError(f"{_where(path, lines, 'tasks')}: TSA is zero-shot and must not have a prompt")
        if t not in TASKS:
            raise PromptTemplateError(f"{_where(path, lines, 'tasks')}: unknown task {t!r}; known: {', '.join(TASKS)}")
    fields = {k: v for k, v in data.items() if k not in ("family", "tasks")}
    for key, value in fields.items():
        if key == "answer_rule" and isinstance(value, dict):
            variants = {v for t in tasks for v in RULE_VARIANTS.get(t, ())}
            if set(value) != variants:
                raise PromptTemplateError(f"{_where(path, lines, key)}: variants must be exactly {sorted(variants)} "
                                          f"for tasks {tasks}, got {sorted(value)}")
            for variant, text in value.items():
                _check_text(text, _where(path, lines, f"{key}.{variant}"), *TEXT_FIELDS[key])
            continue
        if key == "answer_rule" and any(t in RULE_VARIANTS for t in tasks):
            raise PromptTemplateError(f"{_where(path, lines, key)}: must map each variant "
                                      f"{sorted({v for t in tasks for v in RULE_VARIANTS.get(t, ())})} to a rule")
        _check_text(value, _where(path, lines, key), *TEXT_FIELDS[key])
    return Family(name.strip(), tuple(tasks), fields, str(path), lines)


def load_prompts(directory: str | os.PathLike[str] | None = None) -> PromptSet:
    """A validated template set (default: the packaged ``touchcot-v1`` set, read once)."""
    return _default_prompts() if directory is None else _load_dir(Path(directory))


@lru_cache(maxsize=1)
def _default_prompts() -> PromptSet:
    prompts = _load_dir(PROMPT_DIR)
    if prompts.version != PROMPT_VERSION:
        raise PromptTemplateError(f"{prompts.where('version')}: packaged prompts say version {prompts.version!r} "
                                  f"but PROMPT_VERSION is {PROMPT_VERSION!r}; update both together")
    return prompts


def _load_dir(directory: Path) -> PromptSet:
    common_path = directory / COMMON_FILE
    if not common_path.is_file():
        raise PromptTemplateError(f"{directory}: no {COMMON_FILE} (the shared prompt parts)")
    common, lines = _load_common(common_path)
    families: dict[str, Family] = {}
    for path in sorted(directory.glob("*.yaml")):
        if path.name == COMMON_FILE:
            continue
        fam = _load_family(path)
        for task in fam.tasks:
            if task in families:
                raise PromptTemplateError(f"{fam.where('tasks')}: task {task!r} is already covered by "
                                          f"{families[task].file}")
            families[task] = fam
    missing = [t for t in PROMPT_TASKS if t not in families]
    if missing:
        raise PromptTemplateError(f"{directory}: no prompt family covers task(s) {', '.join(missing)}")
    return PromptSet(common["version"].strip(), common, families, str(common_path), lines)


# ------------------------------------------------------------------------------------------- rendering


def prompt_version(reveal_answer: bool = True, prompts: PromptSet | None = None) -> str:
    """What a sample records as its prompt version (blind prompts are a different prompt)."""
    version = (prompts or load_prompts()).version
    return version if reveal_answer else version + BLIND_SUFFIX


def _fill(template: str, where: str, values: Mapping[str, str]) -> str:
    try:
        return template.format_map(values)
    except KeyError as e:
        raise PromptTemplateError(f"{where}: no value for slot {{{e.args[0]}}}") from None


def _quoted(phrases: Sequence[str], last: str = "or") -> str:
    quoted = [f'"{p}"' for p in phrases]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} {last} {quoted[-1]}"


def _task_values(item: QAItem, prompts: PromptSet) -> dict[str, str]:
    """Slot values for guidance and answer rules, taken from the item's vocabulary and gold."""
    hints = prompts.common["hints"]
    values = {"n_videos": str(len(item.videos)), "options": "", "choices": "", "answer_format": "",
              "attribute": "", "attributes": "", "hint": "", "hints": "", "superlative": "", "comparative": ""}
    vocab = get_vocabulary(item.vocabulary)
    attribute = item.task.removeprefix("TFA-") if item.task.startswith("TFA-") else item.gold.get("attribute")
    if attribute in vocab:
        attr = vocab[attribute]
        values |= {"attribute": attribute, "hint": hints[attribute], "choices": _quoted(attr.levels)}
        direction = item.gold.get("direction")
        values["superlative"] = attr.most if direction == "most" else attr.least
        values["comparative"] = attr.more if direction == "more" else attr.less
    names = list(vocab)
    values["attributes"] = ", ".join(names[:-1]) + f" and {names[-1]}"
    values["hints"] = " ".join(f"{a.capitalize()}: {hints[a]}." for a in names)
    if item.task == "TFA-combined":
        values["answer_format"] = COMBINED_SEP.join(f"{a}: <{a} level>" for a in names)
        values["choices"] = "; ".join(f"{a}: {_quoted(vocab[a].levels)}" for a in names)
    if item.task == "OSC":
        values["options"] = ", ".join(f"({letter}) {name}" for letter, name in zip("ABC", item.options, strict=False))
    if item.task == "OCSE":
        values["choices"] = _quoted(item.options or CONTACT_STATES)
    if item.task in ("SFD", "SOI"):
        values["choices"] = _quoted([f"the {o} object" for o in ORDINALS[:len(item.videos)]])
    if item.task == "PC":
        values["choices"] = _quoted(list(PC_RELATIONS))
    return values


def _answer_rule(item: QAItem, prompts: PromptSet) -> tuple[str, str]:
    fam = prompts.family(item.task)
    rule = fam.fields["answer_rule"]
    if isinstance(rule, dict):
        variant = item.gold.get("kind")
        if variant not in rule:
            raise ValueError(f"item {item.id!r} ({item.task}): gold 'kind' {variant!r} has no answer rule in "
                             f"{fam.file} (variants: {', '.join(rule)})")
        return rule[variant], fam.where(f"answer_rule.{variant}")
    return rule, fam.where("answer_rule")


def _teacher_question(question: str) -> str:
    """The question with each ``<tactile>`` placeholder named: the teacher reads text, not video."""
    parts = question.split(PLACEHOLDER)
    out = parts[0]
    for k, rest in enumerate(parts[1:], start=1):
        out += f"[Video {k}]" + rest
    return out.strip()


def render_cue_tables(videos: Sequence[VideoCues], prompts: PromptSet | None = None,
                      segments: Sequence[bool] | None = None) -> str:
    """The per-video cue tables as compact text, one block per video in item order.

    Segments (OCSE) show the segment's trend only, without stage names: those would give the answer away.
    """
    prompts = prompts or load_prompts()
    table = prompts.common["cue_table"]
    blocks = []
    for n, video in enumerate(videos, start=1):
        values = cuetext.cue_slots(video, n)
        is_segment = segments[n - 1] if segments is not None else "seg_area_start" in video.cues

        def line(key: str, values: Mapping[str, str] = values) -> str:
            return cuetext.render(table[key], values, prompts.where(f"cue_table.{key}"))

        if is_segment:
            lines = [line("segment_header"), line("segment")]
        else:
            lines = [line("header")]
            lines += [line(stage) for stage in STAGES if stage in video.phases]
            lines.append(line("surface") if video.phases else line("no_contact"))
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks)


def build_prompt(job: CoTJob, reveal_answer: bool = True, prompts: PromptSet | None = None) -> Prompt:
    """The system and user prompt for one job (``reveal_answer``: tell the teacher the gold answer)."""
    prompts = prompts or load_prompts()
    item = job.item
    fam = prompts.family(item.task)
    values = _task_values(item, prompts)
    guidance = _fill(fam.fields["guidance"], fam.where("guidance"), values)
    rule_text, rule_where = _answer_rule(item, prompts)
    answer_rule = _fill(rule_text, rule_where, values)
    system = _fill(*prompts.text(item.task, "system"), {"guidance": guidance, "answer_rule": answer_rule})
    stages_block = _fill(*prompts.text(item.task, "stages_block"), {"stages": ", ".join(job.stages) or "none"})
    if reveal_answer:
        answer_block = _fill(prompts.common["reveal"], prompts.where("reveal"), {"answer": item.answer})
    else:
        answer_block = _fill(prompts.common["blind"], prompts.where("blind"), {})
    segments = [ref.start is not None or ref.end is not None for ref in item.videos]
    user = _fill(*prompts.text(item.task, "user"), {
        "question": _teacher_question(item.question),
        "cue_tables": render_cue_tables(job.videos, prompts, segments),
        "stages_block": stages_block,
        "answer_block": answer_block,
        "n_videos": str(len(job.videos)),
    })
    return Prompt(system=system.strip(), user=user.strip(), version=prompt_version(reveal_answer, prompts),
                  task=item.task)
