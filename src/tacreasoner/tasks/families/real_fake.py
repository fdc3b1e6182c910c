"""RFOR: is this fruit real or fake."""

from __future__ import annotations

from collections.abc import Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.building import BuildContext, Cycler, balanced, register
from tacreasoner.tasks.schema import QAItem

__all__ = ["rfor"]


def _rfor_targets(n: int | None, real: list, fake: list, ctx: BuildContext) -> list[bool]:
    """Real/fake targets: balanced when both exist; with ``n=None`` each clip once, balanced as far as possible."""
    present = [v for v, pool in ((True, real), (False, fake)) if pool]
    if len(present) == 1:
        ctx.report.notes.append(f"only {'real' if present[0] else 'fake'} fruit clips: RFOR cannot be balanced")
    if n is not None:
        return balanced(present, n, ctx.rng)
    k = min(len(real), len(fake))
    rest = [len(real) > len(fake)] * (len(real) + len(fake) - 2 * k)
    targets = [True, False] * k + rest
    return [targets[i] for i in ctx.rng.permutation(len(targets))]


@register("RFOR")
def rfor(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """RFOR: is this fruit real or fake (clips with ``labels["real"]`` set)."""
    for c in clips:
        if c.is_real is not None and not isinstance(c.is_real, bool):
            raise ValueError(f"clip {c.clip_id!r}: labels['real'] must be true, false or null, got {c.is_real!r}")
    labelled = [c for c in clips if c.is_real is not None]
    ctx.skip(len(clips) - len(labelled), "no real/fake label")
    eligible = [c for c in labelled if c.category]
    ctx.skip(len(labelled) - len(eligible), "no fruit category")
    if not eligible:
        return ctx.finish()
    pools = {True: [c for c in eligible if c.is_real], False: [c for c in eligible if not c.is_real]}
    cyclers = {v: Cycler(pool, ctx.rng) for v, pool in pools.items() if pool}
    plan = [{"real": t} for t in _rfor_targets(n, pools[True], pools[False], ctx)]
    plan = ctx.with_templates(plan, "rfor")

    def attempt(p: dict) -> bool:
        c = cyclers[p["real"]].next()
        return ctx.add((c.clip_id,), p["template"], [c], {"real": p["real"], "fruit": c.category},
                       {"fruit": c.category})

    return ctx.run(plan, attempt, "fruit clip")
