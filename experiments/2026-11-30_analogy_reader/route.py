"""Model-free: which property the reader reads for every labelled one-clip wording of the given held-out sets.

    PYTHONPATH=<worktree of a reader version>/src python experiments/2026-11-30_analogy_reader/route.py \\
        --out runs/words/route_v13_h18.json heldout18

Each set's ``tfa`` wordings carry the property they ask (``attribute``); each is read in every vocabulary that has
that property, with the sentence embedding as the fallback (as the answering modes read them).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tacreasoner.model.sentence_reader import default_property_reader
from tacreasoner.tasks.conclude import asked_properties
from tacreasoner.tasks.paraphrase import load_paraphrases
from tacreasoner.tasks.vocab import get_vocabulary


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("sets", nargs="+")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    reader = default_property_reader()
    rows = []
    for wording in args.sets:
        for p in load_paraphrases(wording).get("tfa", ()):
            for vocab in ("vtv150k", "physiclear"):
                if p.attribute in get_vocabulary(vocab):
                    read = asked_properties(p.template.text.replace("{choices}", ""), vocab, reader)
                    rows.append({"set": wording, "id": p.template.id, "vocabulary": vocab, "asked": p.attribute,
                                 "read": read, "right": read == [p.attribute]})
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=1))
    for vocab in ("vtv150k", "physiclear"):
        mine = [r for r in rows if r["vocabulary"] == vocab]
        print(f"{vocab}: {sum(r['right'] for r in mine)}/{len(mine)} read as exactly the asked property")


if __name__ == "__main__":
    main()
