"""TSA: which of two objects suits a scenario better, from the scenarios in ``tasks/scenarios.yaml`` (zero-shot: never
built for a train split)."""

from __future__ import annotations

from collections.abc import Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.answers import LETTERS, ordinal_answer
from tacreasoner.tasks.building import (
    BuildContext,
    Cycler,
    check_split_allows,
    partner,
    plan_targets,
    ranks_of,
    register,
)
from tacreasoner.tasks.scenarios import Scenario, scenarios_for
from tacreasoner.tasks.schema import QAItem

__all__ = ["TSA_OPTIONS", "tsa"]

TSA_OPTIONS = (ordinal_answer(0), ordinal_answer(1))


@register("TSA")
def tsa(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """TSA: which of two objects suits a scenario better (zero-shot: refuses a train split)."""
    check_split_allows(ctx.task, ctx.split)
    applicable = scenarios_for(ctx.vocabulary, ctx.scenarios)
    if not applicable:
        ctx.report.notes.append(f"no scenario applies to the {ctx.vocabulary} vocabulary")
        return ctx.finish()
    groups: dict[str, dict[int, list[TactileClip]]] = {}
    needed: dict[tuple[str, str], dict[str, int]] = {}
    """(scenario, clip) → the clip's ranks on the scenario's needs."""
    for s in applicable:
        scored: dict[int, list[TactileClip]] = {}
        for c in clips:
            ranks = ranks_of(c, ctx.vocabulary, list(s.needs))
            if ranks is not None:
                needed[s.id, c.clip_id] = ranks
                scored.setdefault(s.score(ranks), []).append(c)
        if len(scored) >= 2:
            groups[s.id] = dict(sorted(scored.items()))
    usable = {clip_id for _, clip_id in needed}
    ctx.skip(len(clips) - len(usable), f"no {ctx.vocabulary} labels for any scenario's needs")
    feasible = [s for s in applicable if s.id in groups]
    if not feasible:
        ctx.report.notes.append("no scenario separates any two clips")
        return ctx.finish()
    cyclers = {s.id: Cycler([c for g in groups[s.id].values() for c in g], ctx.rng) for s in feasible}
    targets = plan_targets(len(usable) if n is None else n, ctx.rng, scenario=feasible, letter=("A", "B"))
    plan = ctx.with_templates(targets, "tsa", within="letter")
    shown = " ".join(f"({letter}) {o}" for letter, o in zip(LETTERS, TSA_OPTIONS, strict=False))

    def attempt(p: dict) -> bool:
        s: Scenario = p["scenario"]
        a = cyclers[s.id].next()
        sa = s.score(needed[s.id, a.clip_id])
        b = partner(groups[s.id], sa, ctx.rng)
        if b is None or b.object_id == a.object_id:
            return False
        sb = s.score(needed[s.id, b.clip_id])
        better, worse = (a, b) if sa > sb else (b, a)
        pair = [better, worse] if p["letter"] == "A" else [worse, better]
        gold = {"letter": p["letter"], "scenario": s.id, "needs": dict(s.needs)}
        ranks = [needed[s.id, c.clip_id] for c in pair]
        meta = {"scenario_text": s.text, "scores": [s.score(r) for r in ranks], "ranks": ranks}
        return ctx.add((*(c.clip_id for c in pair), s.id), p["template"], pair, gold,
                       {"scenario": s.text, "options": shown}, options=TSA_OPTIONS, meta=meta)

    return ctx.run(plan, attempt, "pair of different objects with different scenario scores")
