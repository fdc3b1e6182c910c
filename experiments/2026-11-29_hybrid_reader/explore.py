"""Exploration on development data only (the training wordings, the templates and the held-out sets already read,
3-12): where does the word list read no property or several, and how far is each such question's embedding from
each property's centroid? Prints the similarities the hybrid reader's two thresholds are chosen from.

    python experiments/2026-11-29_hybrid_reader/explore.py ~/.cache/tacreasoner/sentence/all-MiniLM-L6-v2

(As first run it embedded with its own copy of the mean pooling and centroids; it now calls the reader that was built
from it, which fits the same centroids on the same wordings: the printed similarities are the same; the words' own
readings are those of the lexicon version it runs with.)
"""

from __future__ import annotations

import sys
from pathlib import Path

import yaml

from tacreasoner.model.sentence_reader import PropertyReader
from tacreasoner.tasks.conclude import asked_fruit, asked_properties, beyond_touch
from tacreasoner.tasks.vocab import get_vocabulary

PARAPHRASES = Path("src/tacreasoner/tasks/paraphrases")
VOCABULARIES = {"vtv150k": ["hardness", "protrusion", "elasticity", "friction"],
                "physiclear": ["hardness", "roughness", "bumpiness"]}
NEGATIVES = ["<tactile> What colour is this?", "How heavy is the thing in <tactile>?", "<tactile> is it hot or cold?",
             "Who makes this? <tactile>", "<tactile> What does it smell like?", "<tactile> How much would this cost?",
             "<tactile> hi", "<tactile> What is this object?", "Thanks! <tactile>", "<tactile> Is this safe to eat?"]


def fill(text: str, vocabulary: str) -> str:
    names = list(get_vocabulary(vocabulary))
    listed = ", ".join(names[:-1]) + " and " + names[-1]
    return text.replace("{attributes}", listed).replace("{format}", "").replace("{fruit}", "orange")


def main() -> None:
    reader = PropertyReader(Path(sys.argv[1]))  # centroids fitted on the training wordings, as explored here first
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
    for n, kind, vocabulary, text, gold in rows:
        words = asked_properties(text, vocabulary)
        if words is not None and len(words) == 1 and kind == "one":
            continue
        ranked = sorted(((sim, a) for a, sim in reader.similarities(text, vocabulary).items()), reverse=True)
        other = "fruit" if asked_fruit(text) else (beyond_touch(text, vocabulary) or "")
        print(f"h{n:<2} {kind:8} {vocabulary:10} gold={gold} words={words} {other} "
              f"top={ranked[0][1]}:{ranked[0][0]:.2f} 2nd={ranked[1][1]}:{ranked[1][0]:.2f} | "
              f"{text[:90]!r}")


if __name__ == "__main__":
    main()
