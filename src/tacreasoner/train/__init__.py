"""Training loops: encoder and LLM pre-training, Stage I alignment, Stage II SFT."""
