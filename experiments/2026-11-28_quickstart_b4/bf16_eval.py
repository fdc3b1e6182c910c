"""Does answering in bfloat16 (weights cast after loading) change a trained model's val answers? Wraps
`load_trained` so `evaluate`'s own path (predict_split, report) runs on the cast model.

    python experiments/2026-11-28_quickstart_b4/bf16_eval.py MODEL BENCH OUT VIDEO_CACHE
"""

import sys

import torch

import tacreasoner.evaluate.predict as predict
from tacreasoner.evaluate.report import evaluate

model_dir, bench, out, cache = sys.argv[1:5]
plain = predict.load_trained


def load_bf16(*args, **kwargs):
    model, processor = plain(*args, **kwargs)
    return model.to(torch.bfloat16), processor


predict.load_trained = load_bf16
items, preds = predict.predict_split(model_dir, bench, "val", out, batch_size=48, max_new_tokens=64,
                                     video_cache=cache)
print(evaluate(items, [preds], "strict", out).to_markdown())
