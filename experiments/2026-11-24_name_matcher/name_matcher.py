"""Does the cross-video name matcher assign OSC's test videos right, and does the LLM follow it?

Usage: python benchmarks/name_matcher.py --model RUN/stage2/model --scored EVAL/scored/seed0.jsonl --bench BENCH

The matcher (``encoder.cross_video_names``; fitted when Stage II starts) maps each video's encoder output to the
embedding of the object name it expects and gives a prompt that lists as many names as videos the assignment that
fits best; its verdict is written into the prompt's tokens. This reads the saved model's own matcher on every test
OSC item (what it wrote into the prompt) and sets it beside the model's scored answer: how often the matcher is
right, and how often the LLM's answer is right where the matcher is right or wrong. Results:
benchmarks/results/name_matcher.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp


def matcher_assignments(model, processor, bench: Path, cache: Path | None) -> dict[str, list[int]]:
    """Per test OSC item the assignment (option index per video) the model's matcher writes into its prompt."""
    import torch

    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import VideoBank, bench_video_root, video_key

    info, items = load_bench(bench, "test")
    items = [i for i in items if i.task == "OSC"]
    root = bench_video_root(bench, info)
    keys = [[video_key(v, root, i.id) for v in i.videos] for i in items]
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for ks in keys for k in ks], cache_dir=cache)
    fusion = model.projector.cross_video
    if fusion is None or not bool(fusion.names_fitted[3]):
        raise SystemExit("this model has no fitted name matcher (encoder.cross_video with cross_video_names, "
                         "fitted when Stage II starts)")
    out = {}
    with torch.no_grad():
        for item, ks in zip(items, keys, strict=True):
            enc = processor.encode_conversation(processor.messages(item.question), add_generation_prompt=True)
            ids, mask = torch.tensor([enc.input_ids]), torch.tensor([enc.question_mask])
            videos = bank.batch(ks)
            _, features, per_sample, _, options = model.tactile_features(
                ids, videos["pixel_values"], None, mask, videos["sensor_ids"], None)
            if int(options[1][0]) != len(ks):
                raise SystemExit(f"item {item.id}: the processor found {int(options[1][0])} listed options, "
                                 f"expected {len(ks)}")
            places = fusion.places(features, per_sample, options)[0, :len(ks)]  # the video of each option
            out[item.id] = places.argsort().tolist()  # the option of each video
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="a Stage II model directory")
    parser.add_argument("--scored", type=Path, required=True, help="its evaluation's scored/seed*.jsonl")
    parser.add_argument("--bench", type=Path, required=True)
    parser.add_argument("--video-cache", type=Path, default=None)
    args = parser.parse_args()

    import torch

    from tacreasoner.evaluate.predict import load_trained
    from tacreasoner.tasks.bench import load_bench

    torch.set_num_threads(1)
    model, processor = load_trained(args.model, device="cpu")
    base = getattr(model, "get_base_model", lambda: model)()
    assigned = matcher_assignments(base, processor, args.bench, args.video_cache)
    gold = {i.id: list(i.gold["assignment"]) for i in load_bench(args.bench, "test")[1] if i.task == "OSC"}
    scored = {r["id"]: bool(r["correct"]) for r in map(json.loads, args.scored.read_text().splitlines())
              if r["id"] in gold}
    missing = sorted(set(gold) - set(scored))
    if missing:
        raise SystemExit(f"{args.scored}: no scored answer for {len(missing)} test OSC item(s), e.g. {missing[0]}")
    right = {i: assigned[i] == gold[i] for i in gold}
    follow = {kind: [scored[i] for i in gold if right[i] == want] for kind, want in (("right", True), ("wrong", False))}
    result = {"items": len(gold), "matcher_right": sum(right.values()), "llm_right": sum(scored.values()),
              "llm_right_where_matcher_right": [sum(follow["right"]), len(follow["right"])],
              "llm_right_where_matcher_wrong": [sum(follow["wrong"]), len(follow["wrong"])]}
    info = stamp()
    md = header_md("Name matcher: OSC test items, the matcher's assignment and the LLM's answer", info)
    md += (f"Model: `{args.model}`; answers: `{args.scored}`. Chance for a whole assignment of three: 1/6 "
           "(16.7%); a Wilson 95% lower bound above it needs 27.3% right at n = 55.\n\n")
    md += md_table(["test OSC items", "matcher right", "LLM right", "LLM right where the matcher is right",
                    "LLM right where the matcher is wrong"],
                   [[len(gold), result["matcher_right"], result["llm_right"],
                     "{}/{}".format(*result["llm_right_where_matcher_right"]),
                     "{}/{}".format(*result["llm_right_where_matcher_wrong"])]])
    publish("name_matcher", {**info, "model": str(args.model), "scored": str(args.scored), **result}, md)


if __name__ == "__main__":
    main()
