"""Hand-built QA items and CoT samples for the filter, audit and format tests (gold table of tasks/schema.py)."""

from __future__ import annotations

import dataclasses

import numpy as np

from tacreasoner.cot.schema import CoTSample, normalise_output
from tacreasoner.tasks.answers import render_answer
from tacreasoner.tasks.schema import QAItem, VideoRef

OSC_OPTIONS = ["a stone", "a sponge", "a tangerine"]
OCSE_OPTIONS = ["pressing", "holding", "sliding", "rotating", "releasing"]

GOLDS: dict[str, dict] = {
    "TFA-hardness": {"attribute": "hardness", "level": 0},
    "TFA-combined": {"levels": {"hardness": 2, "protrusion": 0, "elasticity": 1, "friction": 2}},
    "SFD": {"kind": "which", "index": 1, "attribute": "hardness", "direction": "more"},
    "SFD-yesno": {"kind": "yesno", "value": True, "attribute": "hardness", "direction": "more"},
    "OSC": {"assignment": [1, 0, 2]},
    "RFOR": {"real": True, "fruit": "tangerine"},
    "OCSE": {"state": "sliding"},
}
N_VIDEOS = {"SFD": 2, "OSC": 3, "SOI": 3, "TSA": 2}
STAGES = {"OCSE": ["slide"], "RFOR": ["press", "hold", "slide", "release"]}
DEFAULT_STAGES = ["press", "hold", "release"]


def make_item(task: str, gold: dict | None = None, *, item_id: str = "", objects: list[str] | None = None,
              split: str = "train", videos: list[VideoRef] | None = None) -> QAItem:
    """A QA item written by hand; ``task`` may be ``SFD-yesno`` for the yes/no SFD variant."""
    real_task = task.removesuffix("-yesno")
    gold = gold if gold is not None else GOLDS[task]
    n = N_VIDEOS.get(real_task, 1)
    options = OSC_OPTIONS if real_task == "OSC" else OCSE_OPTIONS if real_task == "OCSE" else []
    if videos is None:
        segment = (4, 10) if real_task == "OCSE" else (None, None)
        name = item_id or task
        videos = [VideoRef(f"{name}-clip{i}", f"clips/{name}-{i}.mp4", *segment) for i in range(n)]
    return QAItem(id=item_id or f"{task}-item", task=real_task, question=" ".join(["<tactile>"] * n) + " What is it?",
                  answer=render_answer(real_task, gold), gold=gold, videos=videos,
                  objects=objects or [f"{item_id or task}-obj{i}" for i in range(n)], options=options, split=split)


_PRESS = ["During pressing the contact area grows to {a:.2f} of the pad within {n} frames.",
          "As the sensor presses in, the imprint widens steadily to an area fraction of {a:.2f}.",
          "The indentation phase shows a {adj} rise in intensity that peaks near frame {n}.",
          "Pressing leaves a {adj} imprint whose mean intensity climbs to {b:.1f} grey levels."]
_HOLD = ["While holding, the area drifts by only {d:.3f} and the edges stay put.",
         "In the dwell the imprint stays almost constant for {n} frames.",
         "During the hold phase the intensity relaxes by {p} percent before settling."]
_SLIDE = ["When sliding starts, the tint shifts sideways by {d:.3f} and the centroid moves {p} pixels.",
          "Shear during the slide tilts the gel colour, and small stick-slip jumps appear {n} times."]
_ROTATE = ["The twist rotates the contact pattern by about {p} degrees."]
_RELEASE = ["After release the gel recovers within {n} frames and leaves a residual of {d:.3f}.",
            "On lift-off the contact fades {adj}, with {p} percent of the peak left over.",
            "Unloading brings the intensity back towards baseline by frame {n}."]
_POOLS = {"press": _PRESS, "hold": _HOLD, "slide": _SLIDE, "rotate": _ROTATE, "release": _RELEASE}
_ADJ = ["sharp", "gentle", "steep", "slow", "broad", "narrow", "quick", "gradual"]


def varied_think(stages: list[str], conclusion: str, seed: int) -> str:
    """Cue-grounded reasoning covering ``stages``, different enough across seeds not to count as duplicates."""
    rng = np.random.default_rng(seed)
    sentences = []
    for stage in stages:
        pool = _POOLS[stage]
        sentences.append(pool[int(rng.integers(len(pool)))].format(
            a=rng.uniform(0.1, 0.9), n=int(rng.integers(3, 60)), adj=_ADJ[int(rng.integers(len(_ADJ)))],
            b=rng.uniform(5, 40), d=rng.uniform(0.001, 0.2), p=int(rng.integers(2, 90))))
    extra = [f"Sample note {seed}: frame {int(rng.integers(100, 999))} looks {_ADJ[int(rng.integers(len(_ADJ)))]}.",
             f"Reference id {seed * 7919 % 10007} of batch {int(rng.integers(10, 99))}."]
    return " ".join(sentences + extra + [conclusion])


def conclusion_for(task: str, gold: dict) -> str:
    """A conclusion sentence consistent with the gold."""
    answer = render_answer(task.removesuffix("-yesno"), gold)
    if task.startswith("TFA-") and task != "TFA-combined":
        return f"So the object is {answer}."
    if task == "TFA-combined":
        return "Overall, the object is " + ", ".join(p.split(": ")[1] for p in answer.split("; ")) + "."
    if task == "SFD":
        return f"Therefore {answer} is harder than the other."
    if task == "SFD-yesno":
        return f"So {answer}, the first object is harder."
    if task == "OSC":
        return "Therefore " + ", ".join(f"video {p[0]} is {p[2]}" for p in answer.split(", ")) + "."
    if task == "RFOR":
        return f"Hence the fruit is {answer}."
    if task == "OCSE":
        return f"Therefore the sensor is {answer} in this segment."
    raise ValueError(task)


def make_sample(item: QAItem, think: str | None = None, answer: str | None = None, *, key: str = "",
                stages: list[str] | None = None, output: str | None = None, seed: int = 0,
                variant: str | None = None, usage: dict | None = None) -> CoTSample:
    """A CoT sample for ``item`` carrying the item in ``meta["item"]`` (the pipeline's contract)."""
    task = variant or item.task
    stages = stages if stages is not None else STAGES.get(item.task, DEFAULT_STAGES)
    if think is None:
        think = varied_think(stages, conclusion_for(task, item.gold), seed)
    if output is None:
        output = normalise_output(think, item.answer if answer is None else answer)
    return CoTSample(key=key or f"{item.id}-k{seed}", item_id=item.id, task=item.task, split=item.split,
                     objects=list(item.objects), question=item.question, gold_answer=item.answer,
                     videos=[dataclasses.asdict(v) for v in item.videos],
                     output=output, teacher="rules", model="rule-teacher", prompt_version="touchcot-v1",
                     created="2025-01-01T00:00:00Z", stages=stages,
                     cues=[{"clip_id": v.clip_id, "phases": {"press": [2, 6], "hold": [6, 9], "release": [9, 12]},
                            "phase_source": "ground_truth", "cues": {"peak_area": 0.4}, "fps": 25.0}
                           for v in item.videos],
                     usage=usage or {}, meta={"item": item.to_dict()})


def good_sample(task: str, seed: int = 0, **item_kw: object) -> CoTSample:
    """A sample that passes every check for ``task`` (key ``<task>-<seed>``)."""
    item = make_item(task, item_id=f"{task}-{seed}", **item_kw)  # type: ignore[arg-type]
    return make_sample(item, key=f"{task}-{seed}", seed=seed, variant=task)
