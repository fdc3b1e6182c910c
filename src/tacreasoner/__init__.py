"""TacReasoner: tactile-language reasoning with a dynamic-aware tactile encoder."""

__version__ = "0.1.0"
