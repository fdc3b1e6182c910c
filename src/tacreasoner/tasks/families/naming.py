"""OSC: which video shows which of three named objects."""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.answers import LETTERS
from tacreasoner.tasks.building import BuildContext, Cycler, object_label, pick, plan_targets, ranks_of, register
from tacreasoner.tasks.schema import QAItem

__all__ = ["osc"]


@register("OSC")
def osc(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """OSC: match three videos to three object names shown as (A) (B) (C)."""
    attrs = list(ctx.vocab)
    profile = {c.clip_id: r for c in clips if (r := ranks_of(c, ctx.vocabulary, attrs)) is not None}
    labelled = [c for c in clips if c.clip_id in profile]
    ctx.skip(len(clips) - len(labelled), f"missing some {ctx.vocabulary} labels ({', '.join(attrs)})")
    eligible = [c for c in labelled if object_label(c)]
    ctx.skip(len(labelled) - len(eligible), "no object name")
    if len({object_label(c) for c in eligible}) < 3:
        ctx.report.notes.append("fewer than three distinct object names")
        return ctx.finish()
    cycler = Cycler(eligible, ctx.rng)
    plan = ctx.with_templates(plan_targets(len(eligible) if n is None else n, ctx.rng,
                                    assignment=list(itertools.permutations(range(3)))), "osc")

    def attempt(p: dict) -> bool:
        trio = [cycler.next(), pick(eligible, ctx.rng), pick(eligible, ctx.rng)]
        names = [object_label(c) for c in trio]
        ranks = [profile[c.clip_id] for c in trio]
        vectors = {tuple(r.values()) for r in ranks}
        if len({c.object_id for c in trio}) < 3 or len(set(names)) < 3 or len(vectors) < 3:
            return False
        assignment = list(p["assignment"])
        options = [""] * 3
        for v, k in enumerate(assignment):
            options[k] = names[v]
        shown = " ".join(f"({letter}) {name}" for letter, name in zip(LETTERS, options, strict=True))
        return ctx.add(tuple(c.clip_id for c in trio), p["template"], trio, {"assignment": assignment},
                       {"options": shown}, options=options, meta={"ranks": ranks})

    return ctx.run(plan, attempt, "triple of distinguishable objects with distinct names")
