"""Question templates: phrasings live in YAML data files (``tasks/templates/*.yaml``), not in code.

Each file maps a template *kind* to a list of ``{id, text}`` entries. ``text`` is a ``str.format``
string over the slots that kind allows (``{attribute}``, ``{comparative}``, ``{fruit}``, …) and holds
exactly one ``<tactile>`` placeholder (``schema.PLACEHOLDER``) per video of the task. Templates are
validated on load; every error names the file, line and template id, so a bad edit fails loudly
rather than producing malformed questions.
"""

from __future__ import annotations

import string
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.yamlfile import line_of, read_yaml

TEMPLATE_DIR = Path(__file__).parent / "templates"
TEMPLATE_FIELDS = frozenset({"id", "text"})


@dataclass(frozen=True)
class TemplateKind:
    """What a kind of template may and must contain."""

    videos: int
    slots: frozenset[str]
    required: frozenset[str]
    tasks: tuple[str, ...]


def _kind(videos: int, slots: set[str], required: set[str], *tasks: str) -> TemplateKind:
    return TemplateKind(videos, frozenset(slots), frozenset(required), tasks)


KINDS: dict[str, TemplateKind] = {
    "tfa": _kind(1, {"attribute", "choices"}, {"attribute"}, "TFA-<attribute>"),
    "tfa_combined": _kind(1, {"attributes", "format"}, {"attributes"}, "TFA-combined"),
    "sfd_which": _kind(2, {"attribute", "comparative"}, {"comparative"}, "SFD"),
    "sfd_yesno": _kind(2, {"attribute", "comparative"}, {"comparative"}, "SFD"),
    "pc": _kind(2, {"attribute"}, {"attribute"}, "PC"),
    "soi": _kind(3, {"attribute", "superlative"}, {"superlative"}, "SOI"),
    "osc": _kind(3, {"options"}, {"options"}, "OSC"),
    "tsa": _kind(2, {"scenario", "options"}, {"scenario", "options"}, "TSA"),
    "rfor": _kind(1, {"fruit"}, {"fruit"}, "RFOR"),
    "ocse": _kind(1, {"options"}, set(), "OCSE"),
}
"""Template kinds: the number of ``<tactile>`` placeholders, allowed slots and required slots."""


class TemplateError(ValueError):
    """A template file breaks the rules; the message names file, line and template."""


@dataclass(frozen=True)
class Template:
    id: str
    kind: str
    text: str
    file: str = ""
    line: int = 0

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}: template {self.id!r} ({self.kind})"

    def render(self, **values: str) -> str:
        """Fill the slots; a slot without a value is a programming error, reported with the template."""
        missing = slot_names(self.text) - set(values)
        if missing:
            raise ValueError(f"{self.where}: no value for slot(s) {sorted(missing)}")
        return self.text.format_map(values)


def slot_names(text: str) -> set[str]:
    """The ``{slot}`` names of a format string (ValueError on malformed braces)."""
    return {name for _, name, _, _ in string.Formatter().parse(text) if name is not None}


def _check_slots(text: str, kind: TemplateKind, where: str) -> None:
    try:
        parsed = list(string.Formatter().parse(text))
    except ValueError as e:
        raise TemplateError(f"{where}: malformed braces ({e}); write literal braces as {{{{ and }}}}") from None
    names = set()
    for _, name, spec, conversion in parsed:
        if name is None:
            continue
        if not name.isidentifier() or spec or conversion:
            raise TemplateError(f"{where}: slot {{{name}}} must be a bare name like {{attribute}}")
        names.add(name)
    unknown = names - kind.slots
    if unknown:
        raise TemplateError(f"{where}: unknown slot(s) {sorted(unknown)}; allowed: {sorted(kind.slots)}")
    missing = kind.required - names
    if missing:
        raise TemplateError(f"{where}: missing required slot(s) {sorted(missing)}")
    count = text.count(PLACEHOLDER)
    if count != kind.videos:
        raise TemplateError(f"{where}: has {count} {PLACEHOLDER} placeholder(s); this kind needs {kind.videos} "
                            f"(one per video)")


def _parse_entry(path: Path, kind_name: str, data: object, line: int) -> Template:
    """One entry under ``kind_name``, which starts at ``line``."""
    if not isinstance(data, dict):
        raise TemplateError(f"{path}: entries under {kind_name!r} must be mappings with 'id' and 'text'")
    where = f"{path}:{line}"
    unknown = set(data) - TEMPLATE_FIELDS
    if unknown:
        raise TemplateError(f"{where}: unknown field(s) {sorted(unknown)}; allowed: {sorted(TEMPLATE_FIELDS)}")
    for name in sorted(TEMPLATE_FIELDS):
        if not isinstance(data.get(name), str) or not data[name].strip():
            raise TemplateError(f"{where}: field {name!r} must be a non-empty string")
    template = Template(data["id"], kind_name, data["text"].strip(), str(path), line)
    _check_slots(template.text, KINDS[kind_name], template.where)
    return template


def parse_template_file(path: Path) -> list[Template]:
    """All templates of one YAML file, validated."""
    data, lines = read_yaml(path)
    if not isinstance(data, dict):
        raise TemplateError(f"{path}: top level must map template kinds to lists of templates")
    out = []
    for kind_name, entries in data.items():
        if kind_name not in KINDS:
            raise TemplateError(f"{path}:{line_of(lines, ())}: unknown template kind {kind_name!r}; "
                                f"known: {', '.join(KINDS)}")
        if not isinstance(entries, list) or not entries:
            raise TemplateError(f"{path}: {kind_name!r} must be a non-empty list of templates")
        out.extend(_parse_entry(path, kind_name, e, line_of(lines, (kind_name, i))) for i, e in enumerate(entries))
    return out


def load_templates(directory: str | Path | None = None) -> Mapping[str, tuple[Template, ...]]:
    """Templates by kind from every ``*.yaml`` in ``directory`` (default: the package's own bank).

    Template ids must be unique across files, and every kind needs at least one template. The
    package's bank is read once per process; a given directory is re-read on every call.
    """
    return _default_templates() if directory is None else _read_templates(Path(directory))


@lru_cache(maxsize=1)
def _default_templates() -> Mapping[str, tuple[Template, ...]]:
    return _read_templates(TEMPLATE_DIR)


def _read_templates(directory: Path) -> Mapping[str, tuple[Template, ...]]:
    files = sorted(directory.glob("*.yaml"))
    if not files:
        raise TemplateError(f"{directory}: no template files (*.yaml)")
    by_kind: dict[str, list[Template]] = {k: [] for k in KINDS}
    seen: dict[str, Template] = {}
    for path in files:
        for t in parse_template_file(path):
            if t.id in seen:
                raise TemplateError(f"{t.where}: duplicate template id (first defined at "
                                    f"{seen[t.id].file}:{seen[t.id].line})")
            seen[t.id] = t
            by_kind[t.kind].append(t)
    empty = [k for k, ts in by_kind.items() if not ts]
    if empty:
        raise TemplateError(f"{directory}: no templates for kind(s) {', '.join(empty)}")
    return {k: tuple(ts) for k, ts in by_kind.items()}
