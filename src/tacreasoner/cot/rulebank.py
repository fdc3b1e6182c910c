"""The rules teacher's phrase bank (``rules_bank.yaml``): loading and validation.

Kept apart from the teacher so the checks on the data file (sections, slots per section, evidence
cues, coverage of stages, levels and tasks) read on their own; errors name ``file:line`` and entry.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from tacreasoner.cot import cuetext
from tacreasoner.cot.schema import STAGES
from tacreasoner.tasks.schema import CONTACT_STATES
from tacreasoner.yamlfile import line_of, read_yaml

__all__ = ["BANK_FILE", "STAGE_KEYS", "RulesBank", "RulesBankError", "load_bank"]

BANK_FILE = Path(__file__).parent / "rules_bank.yaml"
ACTION_KEY = "action"
STAGE_KEYS = ("press", "hold", ACTION_KEY, "release")
"""Stage keys of the bank's evidence and readings: the moving stage (slide or rotate) is ``action``."""


class RulesBankError(ValueError):
    """The phrase bank breaks the rules; the message names file, line and entry."""


_CUE = cuetext.SLOTS
_SECTION_SLOTS: dict[str, frozenset[str]] = {
    "openers": frozenset({"attribute", "attributes", "fruit", "superlative", "comparative"}),
    "observe": _CUE,
    "readings": frozenset({"attribute", "fruit"}),
    "rfor_readings": frozenset({"fruit"}),
    "rfor_concede": frozenset({"fruit", "cue_label", "value"}),
    "ocse_observe": _CUE,
    "ocse_readings": frozenset(),
    "ocse_concede": frozenset({"state"}),
    "concede": frozenset({"attribute", "cue_label", "value"}),
    "context": frozenset({"attribute"}),
    "connectors": frozenset({"reading"}),
    "context_connectors": frozenset({"reading"}),
    "evidence_clause": frozenset({"cue_label", "value"}),
    "compare_single": frozenset({"stage_label", "cue_label", "value", "n"}),
    "transitions": frozenset(),
    "compare": frozenset({"stage_label", "cue_label", "values"}),
    "value_styles": frozenset({"value", "n"}),
    "tipping": frozenset({"cue_label", "values", "attribute"}),
    "close_call": frozenset({"attribute", "winner", "comparative", "superlative"}),
    "pc_similar": frozenset({"attribute"}),
    "verdict": frozenset({"winner", "comparative", "superlative"}),
    "against": frozenset({"attribute"}),
    "neutral": frozenset({"attribute"}),
    "combined_verdict": frozenset({"attribute", "Attribute", "cue_label", "value", "reading", "phrase"}),
    "osc_profile": frozenset({"n", "cue_label", "value", "profile"}),
    "osc_match": frozenset({"name", "letter", "profile", "n"}),
    "conclusions": frozenset({"answer", "attribute", "comparative", "superlative", "fruit", "winner"}),
    "cue_labels": frozenset(),
    "stage_labels": frozenset(),
    "descriptors": frozenset(),
    "brief_stages": frozenset({"stages"}),
    "brief_feel": frozenset({"n", "descriptor"}),
    "level_feel": frozenset({"n", "descriptor", "level"}),
    "level_rule": frozenset({"direction", "Direction", "attribute", "way", "lx", "ly", "rel", "extreme", "best",
                             "n", "ordinal", "yes_no", "verdict"}),
    "brief_profile": frozenset({"intro", "profile"}),
    "brief_match": frozenset({"n", "profile", "name", "letter"}),
    "brief_ocse": frozenset(),
}
_REQUIRED_SLOTS = {"connectors": frozenset({"reading"}), "context_connectors": frozenset({"reading"}),
                   "value_styles": frozenset({"value", "n"}), "evidence_clause": frozenset({"cue_label", "value"}),
                   "tipping": frozenset({"cue_label", "values"}),
                   # brief-style templates need every slot they allow
                   **{s: _SECTION_SLOTS[s] for s in ("brief_stages", "brief_feel", "brief_profile", "brief_match",
                                                             "level_feel")}}
_DATA_SECTIONS = frozenset({"version", "typical", "evidence", "stage_cue", "ocse_checks"})
CONCLUSION_KEYS = ("TFA", "TFA-combined", "SFD-which", "SFD-yes", "SFD-no", "PC-more", "PC-less", "PC-similar", "SOI",
                   "OSC", "RFOR", "OCSE")
OPENER_KEYS = ("TFA", "TFA-combined", "SFD", "PC", "SOI", "OSC", "RFOR", "OCSE")
LEVEL_RULE_KEYS = ("SFD-which", "SFD-yesno", "SOI")


@dataclass(frozen=True)
class RulesBank:
    data: Mapping[str, Any]
    file: str
    lines: Mapping[tuple, int] = field(default_factory=dict)

    def __getitem__(self, key: str) -> Any:
        return self.data[key]

    @property
    def version(self) -> str:
        return str(self.data["version"])

    def where(self, *at: str | int) -> str:
        return f"{self.file}:{line_of(self.lines, tuple(at))}: {'.'.join(str(a) for a in at)}"


def load_bank(path: str | Path | None = None) -> RulesBank:
    """The validated phrase bank (default: the packaged ``rules_bank.yaml``, read once)."""
    return _default_bank() if path is None else _read_bank(Path(path))


@lru_cache(maxsize=1)
def _default_bank() -> RulesBank:
    return _read_bank(BANK_FILE)


def _read_bank(path: Path) -> RulesBank:
    data, lines = read_yaml(path, RulesBankError)
    bank = RulesBank(data if isinstance(data, dict) else {}, str(path), lines)
    if not isinstance(data, dict):
        raise RulesBankError(f"{path}:1: top level must be a mapping of sections")
    known = set(_SECTION_SLOTS) | _DATA_SECTIONS
    unknown = sorted(set(data) - known)
    if unknown:
        raise RulesBankError(f"{bank.where(unknown[0])}: unknown section(s) {unknown}; known: {sorted(known)}")
    missing = sorted(known - set(data))
    if missing:
        raise RulesBankError(f"{path}: missing section(s) {missing}")
    for section, allowed in _SECTION_SLOTS.items():
        _check_strings(bank, data[section], (section,), allowed, _REQUIRED_SLOTS.get(section, frozenset()))
    _check_data(bank)
    return bank


def _check_strings(bank: RulesBank, node: Any, at: tuple, allowed: frozenset[str], required: frozenset[str]) -> None:
    """Every string under ``node`` is a template using only ``allowed`` slots; no empty lists."""
    if isinstance(node, dict):
        if not node:
            raise RulesBankError(f"{bank.where(*at)}: empty mapping")
        for key, value in node.items():
            _check_strings(bank, value, (*at, key), allowed, required)
    elif isinstance(node, list):
        if not node:
            raise RulesBankError(f"{bank.where(*at)}: empty list (give at least one phrase)")
        for i, value in enumerate(node):
            _check_strings(bank, value, (*at, i), allowed, required)
    elif isinstance(node, str):
        try:
            bad, lacking = cuetext.slot_problems(node, allowed, required)
        except ValueError as e:
            raise RulesBankError(f"{bank.where(*at)}: malformed template ({e})") from None
        if bad:
            raise RulesBankError(f"{bank.where(*at)}: unknown slot(s) {', '.join('{' + s + '}' for s in bad)} "
                                 f"in {node!r}; allowed here: {', '.join(sorted(allowed)) or 'none'}")
        if lacking:
            raise RulesBankError(f"{bank.where(*at)}: {node!r} must contain "
                                 f"{', '.join('{' + s + '}' for s in lacking)}")
    else:
        raise RulesBankError(f"{bank.where(*at)}: expected text, got {type(node).__name__} {node!r}")


def _check_data(bank: RulesBank) -> None:
    from tacreasoner.cot.prepare import ATTRIBUTE_STAGES

    d = bank.data
    for cue, pair in d["typical"].items():
        if cue not in cuetext.CUE_NAMES:
            raise RulesBankError(f"{bank.where('typical', cue)}: unknown cue {cue!r}")
        if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(x, (int, float)) for x in pair)
                and pair[0] <= pair[1]):
            raise RulesBankError(f"{bank.where('typical', cue)}: expected [low, high] numbers, got {pair!r}")
    for attr, stages in d["evidence"].items():
        for stage, cues in stages.items():
            if stage not in STAGE_KEYS:
                raise RulesBankError(f"{bank.where('evidence', attr, stage)}: unknown stage {stage!r}; "
                                     f"use {', '.join(STAGE_KEYS)}")
            for i, entry in enumerate(cues):
                ok = isinstance(entry, list) and len(entry) == 2 and entry[1] in (1, -1)
                if not ok or entry[0] not in d["typical"] or entry[0] not in d["cue_labels"]:
                    raise RulesBankError(f"{bank.where('evidence', attr, stage, i)}: expected [cue, +1|-1] with "
                                         f"the cue in 'typical' and 'cue_labels', got {entry!r}")
            if attr != "real":
                for level in (0, 1, 2):
                    if level not in d["readings"].get(attr, {}).get(stage, {}):
                        raise RulesBankError(f"{bank.where('readings', attr)}: no readings for stage {stage!r}, "
                                             f"level {level}")
    for attr in ATTRIBUTE_STAGES:
        if attr not in d["evidence"] or attr not in d["descriptors"]:
            raise RulesBankError(f"{bank.where('evidence')}: attribute {attr!r} needs evidence and descriptors")
    for stage in STAGES:
        for section in ("stage_cue", "stage_labels", "context", "observe"):
            if stage not in d[section]:
                raise RulesBankError(f"{bank.where(section)}: no entry for stage {stage!r}")
        if d["stage_cue"][stage] not in d["cue_labels"]:
            raise RulesBankError(f"{bank.where('stage_cue', stage)}: cue needs an entry in 'cue_labels'")
    for state in CONTACT_STATES:
        for section in ("ocse_checks", "ocse_readings", "brief_ocse"):
            if state not in d[section]:
                raise RulesBankError(f"{bank.where(section)}: no entry for contact state {state!r}")
        for i, check in enumerate(d["ocse_checks"][state]):
            if not (isinstance(check, list) and len(check) == 3 and check[0] in cuetext.CUE_NAMES
                    and check[1] in ("<", ">") and isinstance(check[2], (int, float))):
                raise RulesBankError(f"{bank.where('ocse_checks', state, i)}: expected [cue, '<'|'>', number], "
                                     f"got {check!r}")
    for section, keys in (("conclusions", CONCLUSION_KEYS), ("openers", OPENER_KEYS), ("verdict", ("SFD", "PC", "SOI")),
                          ("level_rule", LEVEL_RULE_KEYS)):
        lacking = [k for k in keys if k not in d[section]]
        if lacking:
            raise RulesBankError(f"{bank.where(section)}: missing entries for {lacking}")
    for verdict in (True, False):
        if verdict not in d["rfor_readings"].get("hold", {}):
            raise RulesBankError(f"{bank.where('rfor_readings')}: each stage needs 'true' and 'false' readings")
