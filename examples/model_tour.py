"""A tour of the TacReasoner model API in under a minute on a laptop CPU (no training, no downloads).

Builds an untrained tiny model around a freshly trained BPE tokenizer, asks a question about two
simulated clips, streams the (meaningless, untrained) reply, and saves/reloads the model through the
Hugging Face Auto classes (importing ``tacreasoner.model`` registers it with them). Train a real one with
``tacreasoner quickstart``.

    python examples/model_tour.py [--out runs/model_tour]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import torch
from transformers import AutoModelForCausalLM, AutoProcessor, Qwen2Config, TextStreamer

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.model import TacReasonerConfig, TacReasonerForCausalLM, TacReasonerProcessor, TactileEncoderConfig
from tacreasoner.model.tokenizer import train_tokenizer, wording_texts
from tacreasoner.sim.generate import generate_dataset


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=None, help="where to save the model (default: a temporary folder)")
    args = ap.parse_args()
    torch.manual_seed(0)

    # 1. Two simulated clips: the first two catalogue objects (a real and a fake fruit), Mini-style sensor. Their
    #    folder is removed at the end (clips read their frames from it).
    with tempfile.TemporaryDirectory(prefix="tour-sim-") as sim_dir:
        generate_dataset(Path(sim_dir), n_objects=2, repeats=1, sensors=["mini"], seed=0, workers=1)
        tour(Path(sim_dir), args.out)


def tour(sim_dir: Path, out: Path | None) -> None:
    """Steps 1–4 on the clips simulated in ``sim_dir``; the model is saved to ``out`` (default: a temporary folder)."""
    clips = list(read_sim_dataset(sim_dir))
    print("clips:", [(c.object_name, c.sensor, c.n_frames) for c in clips])

    # 2. Tokenizer (byte-level BPE on the project's own wording) + an untrained 2-layer Qwen2 + the tactile encoder.
    #    (A real model wraps a pretrained LLM instead: `tacreasoner llm get smollm2` and model.build.build_model.)
    tokenizer = train_tokenizer(wording_texts(), vocab_size=2048)
    encoder = TactileEncoderConfig()  # the tiny defaults: 8 frames of 64×64, 5 tactile tokens per video
    processor = TacReasonerProcessor.for_encoder(tokenizer, encoder)
    text = Qwen2Config(vocab_size=len(tokenizer), hidden_size=128, num_hidden_layers=2, num_attention_heads=4,
                       num_key_value_heads=2, intermediate_size=256, tie_word_embeddings=True)
    config = TacReasonerConfig(text_config=text.to_dict(), encoder=encoder.to_dict(),
                               tactile_token_id=processor.tactile_token_id)
    model = TacReasonerForCausalLM(config).eval()
    print(f"parameters: {sum(p.numel() for p in model.parameters()) / 1e6:.1f} M")

    # 3. One question, two videos: each <tactile> becomes 5 placeholder tokens the encoder fills in.
    question = "Which object is softer, the first <tactile> or the second <tactile>?"
    inputs = processor.prompt(question, clips)
    print("input ids:", tuple(inputs["input_ids"].shape), "videos:", tuple(inputs["pixel_values"].shape))
    reply = model.answer(processor, question, clips, max_new_tokens=24,
                         streamer=TextStreamer(tokenizer, skip_special_tokens=True))
    print("parsed:", reply.think, "|", reply.answer)

    # 4. Save model + processor together; load them back with the Auto classes.
    out = out or Path(tempfile.mkdtemp(prefix="tour-model-"))
    model.save_pretrained(out)
    processor.save_pretrained(out)
    again = AutoModelForCausalLM.from_pretrained(out).eval()
    again_processor = AutoProcessor.from_pretrained(out)
    with torch.no_grad():
        same = torch.equal(model(**inputs).logits, again(**again_processor.prompt(question, clips)).logits)
    print(f"saved to {out}; reloaded with AutoModelForCausalLM: identical logits = {same}")


if __name__ == "__main__":
    main()
