"""Cue values as the short strings prompts and reasoning cite ("41%", "+3.2%", "0.96 s").

One formatter for both the teacher prompt and the rule-based teacher, so a number quoted in a
reasoning trace is exactly the number the prompt showed. Template files refer to cues by slot name
(the cue's own name, e.g. ``{max_area}``, or a derived slot such as ``{press_span}``); the set of
known slots lets templates be validated when they are loaded, not when a job first uses them.
"""

from __future__ import annotations

from collections.abc import Mapping, Set

from tacreasoner.cot.schema import STAGES, VideoCues
from tacreasoner.tasks.templating import slot_names

PERCENT = frozenset({"max_area", "press_area", "residual", "release_intensity", "contact_fraction", "time_to_max",
                     "seg_area_start", "seg_area_end"})
"""Fractions shown as percentages."""
SIGNED_PERCENT = frozenset({"creep", "hold_intensity_change", "action_intensity_change", "seg_area_change",
                            "seg_intensity_change"})
"""Relative changes shown as signed percentages."""
SECONDS = frozenset({"duration_s", "time_to_max_contact_s", "release_time_s",
                     *(f"{s}_{edge}_s" for s in STAGES for edge in ("start", "end"))})
PIXELS = frozenset({"centroid_jitter", "action_travel_px", "seg_travel_px"})
PLAIN = frozenset({"bump_energy", "bump_ratio", "shear_tint", "shear_tint_ratio", "peak_intensity", "peak_gradient",
                   "sharpness", "intensity_per_area", "texture_energy", "texture_ratio", "press_jump", "shear_cv",
                   "shear_peak", "action_energy", "seg_motion"})
CUE_NAMES = PERCENT | SIGNED_PERCENT | SECONDS | PIXELS | PLAIN
"""Every cue :mod:`tacreasoner.cot.prepare` can measure."""
DERIVED = frozenset({"n", "clip", "duration", "action", "action_noun", "action_verb", "phase_source",
                     *(f"{s}_{k}" for s in STAGES for k in ("span", "dur"))})
"""Slots computed from the cue table: video number, stage spans ("0.76–1.72 s"), the action's names."""
SLOTS = CUE_NAMES | DERIVED
MISSING = "n/a"
ACTION_WORDS = {"slide": ("slide", "sliding"), "rotate": ("rotation", "rotating")}


def format_cue(name: str, value: float) -> str:
    """The display string of one cue value (unknown names: a plain number)."""
    if name in PERCENT:
        pct = 100.0 * value
        return f"{pct:.0f}%" if abs(pct) >= 10 else f"{pct:.1f}%"
    if name in SIGNED_PERCENT:
        return f"{round(100.0 * value, 1) + 0.0:+.1f}%"  # + 0.0: no "-0.0%"
    if name in SECONDS:
        return f"{value:.2f} s"
    if name in PIXELS:
        return f"{value:.1f} px" if abs(value) < 100 else f"{value:.0f} px"
    return _plain(value)


def _plain(value: float) -> str:
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 10:
        return f"{value:.1f}"
    return f"{value:.2f}"


def cue_slots(video: VideoCues, n: int = 1) -> dict[str, str]:
    """All slot values of one video (``n`` = its 1-based number in the item)."""
    out = {name: format_cue(name, value) for name, value in video.cues.items()}
    out["n"] = str(n)
    out["clip"] = video.clip_id
    out["duration"] = out.get("duration_s", MISSING)
    out["phase_source"] = ("simulator ground truth" if video.phase_source == "ground_truth"
                           else "detected from the pixels")
    actions = [s for s in ACTION_WORDS if s in video.phases]
    noun, verb = ACTION_WORDS[actions[0]] if actions else ("movement", "moving")
    out["action"], out["action_noun"], out["action_verb"] = actions[0] if actions else "move", noun, verb
    fps = video.fps or 1.0
    for stage, (s, e) in video.phases.items():
        start, end = video.cues.get(f"{stage}_start_s", s / fps), video.cues.get(f"{stage}_end_s", e / fps)
        out[f"{stage}_span"] = f"{start:.2f}–{end:.2f} s"
        out[f"{stage}_dur"] = f"{end - start:.2f} s"
    return out


class SlotValues(dict):
    """``str.format_map`` mapping: known slots without a value read ``n/a``; unknown ones raise."""

    def __missing__(self, key: str) -> str:
        if key in SLOTS:
            return MISSING
        raise KeyError(key)


def render(template: str, values: Mapping[str, str], where: str = "template") -> str:
    """Fill ``template``; an unknown slot is an error naming ``where`` (file:line of the template)."""
    try:
        return template.format_map(SlotValues(values))
    except KeyError as e:
        raise ValueError(f"{where}: unknown slot {{{e.args[0]}}}") from None
    except (ValueError, IndexError) as e:
        raise ValueError(f"{where}: malformed template ({e})") from None


def slot_problems(text: str, allowed: Set[str], required: Set[str]) -> tuple[list[str], list[str]]:
    """``(unknown, missing)``: the template's slots not in ``allowed`` and the ``required`` ones it lacks, sorted.

    Both empty means the template is fine; malformed braces raise ValueError (callers add ``file:line``).
    """
    slots = slot_names(text)
    return sorted(slots - allowed), sorted(required - slots)
