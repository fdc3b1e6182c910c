"""TacReasoner: tactile-language reasoning with a dynamic-aware tactile encoder.

Importing the package imports nothing else, so ``tacreasoner.sim`` or the CLI stay free of torch. The
model registers itself with transformers' Auto classes when ``tacreasoner.model`` is imported.
"""

__version__ = "0.1.0"
