"""World knowledge for the tiny LLM: a generated, text-only commonsense corpus with a held-out evaluation.

See ``corpus.py`` for what the corpus holds and never holds, and ``docs/tiny-llm.md``.
"""

from tacreasoner.knowledge.corpus import EVAL_KINDS, Corpus, EvalQuestion, build_corpus, chatml, normalise_answer
from tacreasoner.knowledge.facts import KnowledgeObject, knowledge_objects, load_wording

__all__ = ["EVAL_KINDS", "Corpus", "EvalQuestion", "KnowledgeObject", "build_corpus", "chatml", "knowledge_objects",
           "load_wording", "normalise_answer"]
