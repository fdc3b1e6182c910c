"""Comparing objects on one property: SFD (which of two is more X), PC (more, less or similar, Octopi's property
comparison) and SOI (the most or least X of three)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.building import (
    BuildContext,
    Cycler,
    labelled_any,
    partner,
    pick,
    plan_targets,
    rank_groups,
    rank_of,
    register,
)
from tacreasoner.tasks.schema import PC_RELATIONS, QAItem

__all__ = ["pc", "sfd", "soi"]

_SFD_ANSWERS = (("which", 0), ("which", 1), ("yesno", True), ("yesno", False))


def _pairwise_pools(clips: Sequence[TactileClip], ctx: BuildContext
                    ) -> tuple[list[TactileClip], dict[str, dict[int, list[TactileClip]]], list[str], dict] | None:
    """SFD/PC: the labelled clips, their rank groups per attribute, the attributes with two ranks or more and a
    cycler over each one's clips; None (noted) when no attribute has two ranks."""
    labelled = labelled_any(clips, ctx)
    groups = {a: rank_groups(labelled, ctx.vocabulary, a) for a in ctx.vocab}
    attrs = [a for a, g in groups.items() if len(g) >= 2]
    if not attrs:
        ctx.report.notes.append("no attribute has two different ranks among the clips")
        return None
    return labelled, groups, attrs, {a: Cycler([c for g in groups[a].values() for c in g], ctx.rng) for a in attrs}


@register("SFD")
def sfd(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """SFD: which of two objects is more/less X, or a yes/no comparison; never a tie."""
    pools = _pairwise_pools(clips, ctx)
    if pools is None:
        return ctx.finish()
    labelled, groups, attrs, cyclers = pools
    plan = plan_targets(len(labelled) if n is None else n, ctx.rng, attribute=attrs, direction=("more", "less"),
                 answer=_SFD_ANSWERS)
    plan = ctx.with_templates(plan, lambda p: f"sfd_{p['answer'][0]}")

    def attempt(p: dict) -> bool:
        a_name, direction, (kind, value) = p["attribute"], p["direction"], p["answer"]
        a = cyclers[a_name].next()
        ra = rank_of(a, ctx.vocabulary, a_name)
        b = partner(groups[a_name], ra, ctx.rng)
        if b is None or b.object_id == a.object_id:
            return False
        rb = rank_of(b, ctx.vocabulary, a_name)
        winner, loser = (a, b) if (ra > rb) == (direction == "more") else (b, a)
        winner_pos = value if kind == "which" else (0 if value else 1)
        pair = [winner, loser] if winner_pos == 0 else [loser, winner]
        gold = ({"kind": "which", "index": value} if kind == "which" else {"kind": "yesno", "value": value})
        gold |= {"attribute": a_name, "direction": direction}
        attr = ctx.vocab[a_name]
        slots = {"attribute": a_name, "comparative": attr.more if direction == "more" else attr.less}
        ranks = [rank_of(c, ctx.vocabulary, a_name) for c in pair]
        key = (*(c.clip_id for c in pair), a_name, direction, kind)
        return ctx.add(key, p["template"], pair, gold, slots, meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "pair of different objects with different ranks")


@register("PC")
def pc(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """PC (Octopi's property comparison): more, less or similar X in the first object than in the second, each
    relation equally often; "similar" pairs two different objects of the same level."""
    pools = _pairwise_pools(clips, ctx)
    if pools is None:
        return ctx.finish()
    labelled, groups, attrs, cyclers = pools
    plan = ctx.with_templates(plan_targets(len(labelled) if n is None else n, ctx.rng, attribute=attrs,
                                    relation=PC_RELATIONS), "pc")
    beyond = {"more": lambda r, ra: r < ra, "less": lambda r, ra: r > ra, "similar": lambda r, ra: r == ra}

    def attempt(p: dict) -> bool:
        a_name, relation = p["attribute"], p["relation"]
        a = cyclers[a_name].next()
        ra = rank_of(a, ctx.vocabulary, a_name)
        pool = [c for r, g in groups[a_name].items() if beyond[relation](r, ra) for c in g
                if c.object_id != a.object_id]
        if not pool:
            return False
        b = pick(pool, ctx.rng)
        gold = {"attribute": a_name, "relation": relation}
        ranks = [ra, rank_of(b, ctx.vocabulary, a_name)]
        return ctx.add((a.clip_id, b.clip_id, a_name), p["template"], [a, b], gold, {"attribute": a_name},
                       meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "pair of different objects in that relation")


def _extreme_pools(groups: Mapping[int, list[TactileClip]]) -> dict[str, tuple[list, dict[int, list]]]:
    """Per direction: clips that can be a unique extreme, and per rank the clips strictly beyond it.

    A clip can be the unique extreme when at least two other objects rank strictly beyond it.
    """
    out = {}
    for direction, beyond in (("most", lambda r, q: q < r), ("least", lambda r, q: q > r)):
        extremes, others = [], {}
        for r, g in groups.items():
            others[r] = [c for q, h in groups.items() if beyond(r, q) for c in h]
            if len({c.object_id for c in others[r]}) >= 2:
                extremes.extend(g)
        if extremes:
            out[direction] = (extremes, others)
    return out


@register("SOI")
def soi(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """SOI: the most/least X of three objects, with a unique extreme."""
    labelled = labelled_any(clips, ctx)
    groups = {a: rank_groups(labelled, ctx.vocabulary, a) for a in ctx.vocab}
    pools = {(a, d): pool for a in ctx.vocab for d, pool in _extreme_pools(groups[a]).items()}
    if not pools:
        ctx.report.notes.append("no attribute has a rank with two other objects ranked strictly beyond it")
        return ctx.finish()
    cyclers = {k: Cycler(extremes, ctx.rng) for k, (extremes, _) in pools.items()}
    plan = ctx.with_templates(plan_targets(len(labelled) if n is None else n, ctx.rng, combo=list(pools),
                                    index=(0, 1, 2)), "soi")

    def attempt(p: dict) -> bool:
        (a_name, direction), index = p["combo"], p["index"]
        e = cyclers[p["combo"]].next()
        candidates = pools[p["combo"]][1][rank_of(e, ctx.vocabulary, a_name)]
        i, j = ctx.rng.choice(len(candidates), size=2, replace=False)
        others = [candidates[i], candidates[j]]
        if len({e.object_id, *(c.object_id for c in others)}) < 3:
            return False
        trio = [*others[:index], e, *others[index:]]
        attr = ctx.vocab[a_name]
        slots = {"attribute": a_name, "superlative": attr.most if direction == "most" else attr.least}
        gold = {"index": index, "attribute": a_name, "direction": direction}
        ranks = [rank_of(c, ctx.vocabulary, a_name) for c in trio]
        key = (*(c.clip_id for c in trio), a_name, direction)
        return ctx.add(key, p["template"], trio, gold, slots, meta={"attribute": a_name, "ranks": ranks})

    return ctx.run(plan, attempt, "triple with a unique extreme")
