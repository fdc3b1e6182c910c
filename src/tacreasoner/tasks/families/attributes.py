"""TFA: one object's level of one property (TFA-<attribute>), or of every property (TFA-combined)."""

from __future__ import annotations

from collections.abc import Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.building import BuildContext, join_words, rank_of, ranks_of, register
from tacreasoner.tasks.schema import TFA_TASKS, QAItem

__all__ = ["tfa", "tfa_combined"]


@register(*(t for t in TFA_TASKS if t != "TFA-combined"))
def tfa(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """TFA-<attribute>: the level phrase of one property of one object (the attribute is in the task's name)."""
    attribute = ctx.task.removeprefix("TFA-")
    attr = ctx.vocab[attribute]
    eligible = [c for c in clips if rank_of(c, ctx.vocabulary, attribute) is not None]
    start = ctx.clip_plan(clips, eligible, f"no {ctx.vocabulary} label for {attribute}", "tfa", n)
    if start is None:
        return ctx.finish()
    cycler, plan = start
    choices = attr.choices

    def attempt(p: dict) -> bool:
        c = cycler.next()
        level = rank_of(c, ctx.vocabulary, attribute)
        return ctx.add((c.clip_id,), p["template"], [c], {"attribute": attribute, "level": level},
                       {"attribute": attribute, "choices": choices}, meta={"attribute": attribute, "ranks": [level]})

    return ctx.run(plan, attempt, "clip")


@register("TFA-combined")
def tfa_combined(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """TFA-combined: every property of one object, ``attribute: phrase; …`` in vocabulary order."""
    attrs = list(ctx.vocab)
    eligible = [c for c in clips if ranks_of(c, ctx.vocabulary, attrs) is not None]
    start = ctx.clip_plan(clips, eligible, f"missing some {ctx.vocabulary} labels ({', '.join(attrs)})",
                          "tfa_combined", n)
    if start is None:
        return ctx.finish()
    cycler, plan = start
    slots = {"attributes": join_words(attrs), "format": "; ".join(f"{a}: …" for a in attrs)}

    def attempt(p: dict) -> bool:
        c = cycler.next()
        levels = ranks_of(c, ctx.vocabulary, attrs)
        return ctx.add((c.clip_id,), p["template"], [c], {"levels": levels}, slots, meta={"ranks": [levels]})

    return ctx.run(plan, attempt, "clip")
