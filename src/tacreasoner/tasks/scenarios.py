"""The TSA scenario bank: everyday activities and the tactile properties they need (``scenarios.yaml``).

TSA is zero-shot: the bank exists for evaluation only and builders refuse to put TSA into a train
split. Which of two objects suits a scenario better is decided by the labels alone: the sum over the
scenario's needs of ``rank`` (need "high") or ``2 - rank`` (need "low").
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from tacreasoner.tasks.vocab import VOCABULARIES, get_vocabulary
from tacreasoner.yamlfile import line_of, read_yaml

SCENARIO_FILE = Path(__file__).parent / "scenarios.yaml"
SCENARIO_FIELDS = frozenset({"id", "text", "needs"})
NEED_LEVELS = ("high", "low")


@dataclass(frozen=True)
class Scenario:
    id: str
    text: str
    """An activity phrase that reads after "an object for …", e.g. "scraping frost off a car windscreen"."""
    needs: Mapping[str, str]
    """attribute → "high" | "low"."""
    file: str = ""
    line: int = 0

    def applies_to(self, vocabulary: str) -> bool:
        """Usable with a vocabulary only when that vocabulary has every needed attribute."""
        return set(self.needs) <= set(get_vocabulary(vocabulary))

    def score(self, ranks: Mapping[str, int]) -> int:
        """Suitability of an object with these ranks (higher is better)."""
        return suitability(self.needs, ranks)


def suitability(needs: Mapping[str, str], ranks: Mapping[str, int]) -> int:
    """How well an object with ``ranks`` meets ``needs`` (attribute → "high" | "low"): the sum over needs of the rank
    or 2 − rank. The one rule TSA's gold, its reasoning and its consistency check share."""
    return sum(ranks[a] if level == "high" else 2 - ranks[a] for a, level in needs.items())


def _all_attributes() -> set[str]:
    return {a for vocab in VOCABULARIES.values() for a in vocab}


def _parse_scenario(path: Path, data: object, line: int) -> Scenario:
    """One entry of the bank, which starts at ``line``."""
    if not isinstance(data, dict):
        raise ValueError(f"{path}: each scenario must be a mapping with id, text and needs")
    where = f"{path}:{line}"
    unknown = set(data) - SCENARIO_FIELDS
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {sorted(unknown)}; allowed: {sorted(SCENARIO_FIELDS)}")
    for name in ("id", "text"):
        if not isinstance(data.get(name), str) or not data[name].strip():
            raise ValueError(f"{where}: field {name!r} must be a non-empty string")
    where = f"{where}: scenario {data['id']!r}"
    needs = data.get("needs")
    if not isinstance(needs, dict) or not needs:
        raise ValueError(f"{where}: field 'needs' must map attributes to 'high' or 'low'")
    known = _all_attributes()
    for attribute, level in needs.items():
        if attribute not in known:
            raise ValueError(f"{where}: unknown attribute {attribute!r} in needs; known: {sorted(known)}")
        if level not in NEED_LEVELS:
            raise ValueError(f"{where}: need for {attribute!r} must be 'high' or 'low', got {level!r}")
    return Scenario(data["id"], data["text"].strip(), dict(needs), str(path), line)


def load_scenarios(path: str | Path | None = None) -> tuple[Scenario, ...]:
    """All scenarios of a bank file (default: the package's ``scenarios.yaml``, read once), validated."""
    return _default_scenarios() if path is None else _read_scenarios(Path(path))


@lru_cache(maxsize=1)
def _default_scenarios() -> tuple[Scenario, ...]:
    return _read_scenarios(SCENARIO_FILE)


def _read_scenarios(path: Path) -> tuple[Scenario, ...]:
    data, lines = read_yaml(path)
    if not isinstance(data, dict) or not isinstance(data.get("scenarios"), list):
        raise ValueError(f"{path}: top level must be a mapping with a 'scenarios' list")
    extra = set(data) - {"scenarios"}
    if extra:
        raise ValueError(f"{path}: unknown top-level key(s) {sorted(extra)}")
    out: list[Scenario] = []
    seen: dict[str, Scenario] = {}
    for i, entry in enumerate(data["scenarios"]):
        s = _parse_scenario(path, entry, line_of(lines, ("scenarios", i)))
        if s.id in seen:
            raise ValueError(f"{path}:{s.line}: duplicate scenario id {s.id!r} (first at line {seen[s.id].line})")
        seen[s.id] = s
        out.append(s)
    if not out:
        raise ValueError(f"{path}: no scenarios")
    return tuple(out)


def scenarios_for(vocabulary: str, scenarios: tuple[Scenario, ...] | None = None) -> tuple[Scenario, ...]:
    """The scenarios whose needs a vocabulary can express."""
    bank = load_scenarios() if scenarios is None else scenarios
    return tuple(s for s in bank if s.applies_to(vocabulary))
