"""Would nearest-neighbour retrieval over the *training* scenario bank tell what an unseen scenario needs?

Leave-one-out over tasks/scenarios_train.yaml only (the evaluation bank is not read): each training scenario's needs
are predicted from the others' by word-overlap (TF-IDF cosine over content words, k neighbours, vote per
attribute), and scored by (a) exact needs and (b) the decision: over every pair of level profiles whose true
suitability differs, how often the predicted needs pick the same one. Decides whether retrieval is worth building.
"""

from __future__ import annotations

import itertools
import math
import re
from collections import Counter

from tacreasoner.cot.knowledge import SCENARIO_FILE
from tacreasoner.tasks.scenarios import load_scenarios, scenarios_for, suitability
from tacreasoner.tasks.vocab import get_vocabulary

STOP = set("a an the of on in with and for to it its your you so that from by at into off as or is be do not up".split())


def words(text: str) -> list[str]:
    out = []
    for w in re.findall(r"[a-z]+", text.lower()):
        if w in STOP or len(w) < 3:
            continue
        for suffix in ("ing", "es", "s", "ed"):
            if w.endswith(suffix) and len(w) - len(suffix) >= 3:
                w = w[: -len(suffix)]
                break
        out.append(w)
    return out


def main() -> None:
    for vocabulary in ("physiclear", "vtv150k"):
        bank = scenarios_for(vocabulary, load_scenarios(SCENARIO_FILE))
        attrs = list(get_vocabulary(vocabulary))
        docs = [Counter(words(s.text)) for s in bank]
        df = Counter(w for d in docs for w in d)
        n = len(docs)

        def vec(d: Counter) -> dict[str, float]:
            v = {w: c * math.log((n + 1) / (df[w] + 1)) for w, c in d.items()}
            norm = math.sqrt(sum(x * x for x in v.values())) or 1.0
            return {w: x / norm for w, x in v.items()}

        vecs = [vec(d) for d in docs]
        profiles = list(itertools.product(range(3), repeat=len(attrs)))
        for k in (1, 3, 5):
            exact = agree = total = overlap_none = 0
            for i, s in enumerate(bank):
                sims = sorted(((sum(vecs[i].get(w, 0) * x for w, x in vecs[j].items()), j)
                               for j in range(n) if j != i), reverse=True)[:k]
                if sims[0][0] == 0:
                    overlap_none += 1
                votes: dict[str, Counter] = {}
                for sim, j in sims:
                    for a, level in bank[j].needs.items():
                        votes.setdefault(a, Counter())[level] += sim or 1e-6
                top = max((sum(c.values()), a) for a, c in votes.items())[0] if votes else 0
                predicted = {a: c.most_common(1)[0][0] for a, c in votes.items() if sum(c.values()) >= top / 2}
                exact += predicted == dict(s.needs)
                for p, q in itertools.combinations(profiles, 2):
                    rp, rq = dict(zip(attrs, p)), dict(zip(attrs, q))
                    true = suitability(s.needs, rp) - suitability(s.needs, rq)
                    if true == 0:
                        continue
                    guess = suitability(predicted, rp) - suitability(predicted, rq)
                    total += 1
                    agree += (guess > 0) == (true > 0) and guess != 0
            print(f"{vocabulary}: {n} training scenarios, k={k}: exact needs {exact / n:.1%}, decisions agreeing "
                  f"{agree / total:.1%} (ties count as wrong), no word shared with any other: {overlap_none}")


if __name__ == "__main__":
    main()
