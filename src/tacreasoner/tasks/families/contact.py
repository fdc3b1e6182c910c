"""OCSE: the contact state (pressing, holding, sliding, rotating, releasing) of a segment of one clip."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from tacreasoner.data.clip import TactileClip
from tacreasoner.tasks.building import BuildContext, pick, register, video_ref
from tacreasoner.tasks.schema import CONTACT_STATES, PHASE_TO_STATE, QAItem

__all__ = ["MIN_SEGMENT", "contact_runs", "ocse"]

MIN_SEGMENT = 4
"""Shortest contact-phase run (and segment) in frames."""


def contact_runs(phases: Sequence[str], min_length: int = MIN_SEGMENT) -> list[tuple[str, int, int]]:
    """Maximal runs ``(state, start, end)`` of one contact phase lasting at least ``min_length`` frames."""
    runs, start = [], 0
    for i in range(1, len(phases) + 1):
        if i == len(phases) or phases[i] != phases[start]:
            state = PHASE_TO_STATE.get(phases[start])
            if state is not None and i - start >= min_length:
                runs.append((state, start, i))
            start = i
    return runs


@register("OCSE")
def ocse(clips: Sequence[TactileClip], n: int | None, ctx: BuildContext) -> list[QAItem]:
    """OCSE: the contact state of a segment inside one contact-phase run of a clip."""
    phases = {c.clip_id: list(c.phases or []) for c in clips}
    with_phases = [c for c in clips if phases[c.clip_id]]
    ctx.skip(len(clips) - len(with_phases), "no per-frame phases")
    consistent = [c for c in with_phases if c.n_frames is None or len(phases[c.clip_id]) == c.n_frames]
    ctx.skip(len(with_phases) - len(consistent), "phase list length differs from n_frames")
    runs = {c.clip_id: contact_runs(phases[c.clip_id]) for c in consistent}
    eligible = [c for c in consistent if runs[c.clip_id]]
    start = ctx.clip_plan(consistent, eligible, f"no contact phase lasting {MIN_SEGMENT}+ frames", "ocse", n)
    if start is None:
        return ctx.finish()
    cycler, plan = start
    used: Counter = Counter()
    options = list(CONTACT_STATES)

    def attempt(p: dict) -> bool:
        c = cycler.next()
        states = [s for s in CONTACT_STATES if any(r[0] == s for r in runs[c.clip_id])]
        fewest = min(used[s] for s in states)
        state = pick([s for s in states if used[s] == fewest], ctx.rng)
        _, r0, r1 = pick([r for r in runs[c.clip_id] if r[0] == state], ctx.rng)
        length = int(ctx.rng.integers(MIN_SEGMENT, r1 - r0 + 1))
        start = r0 + int(ctx.rng.integers(0, r1 - r0 - length + 1))
        meta = {"phase": phases[c.clip_id][start], "run": [r0, r1], "action": c.action}
        added = ctx.add((c.clip_id, start, start + length), p["template"], [c], {"state": state},
                        {"options": ", ".join(options)}, videos=[video_ref(c, start, start + length)],
                        options=options, meta=meta)
        used[state] += added
        return added

    return ctx.run(plan, attempt, "segment")
