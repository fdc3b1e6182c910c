"""How much GPU memory a training stage needs per GPU, before renting the GPUs (``tacreasoner memory-plan``).

The model is built on the meta device (shapes, no weights, no download) exactly as the trainer builds it, and
:func:`tacreasoner.model.stages.configure_stage` decides what trains, so the parameter counts are the trainer's
own for any architecture: Qwen2.5-7B/14B from their published sizes (:data:`PRESETS`), or any local model
directory's ``config.json``. Everything else is arithmetic on those counts (:func:`plan_memory`).

Per GPU, in bytes (GB = 10⁹ bytes):

* **frozen weights**: every frozen parameter in its own dtype (``model.dtype``; the tactile encoder included).
* **trainable parameters**: fp32 master weights, whatever ``model.dtype`` (the trainer's
  ``master_weights_in_fp32``; compute runs under bf16 autocast).
* **gradients**: one per trainable parameter, in fp32.
* **AdamW state**: two fp32 moments (8 bytes) per trainable parameter.
* **gathered weights** (FSDP, ZeRO-3 on more than one GPU): the full weights of the block being run and of the
  one prefetched: 2 × the largest of one decoder layer and the embedding or output matrix.
* **activations**, for ``b`` = batch size per GPU, ``s`` = ``data.max_length`` (every example as long as allowed),
  ``e`` = bytes per activation (2 under bf16/fp16, else 4), ``h`` hidden size, ``L`` layers, ``a`` attention heads
  of width ``d``, ``k`` key/value heads, ``f`` MLP width, ``V`` vocabulary rows::

      per token and layer  B = e·(4h + 2·a·d + 2·k·d + 4f)          RMSNorm in/out ×2, q + attention out, k, v,
                                                                   SwiGLU gate, up, SiLU(gate), product
                             + Σ_LoRA targets [e·(in + r) + in]    dropout output, A·x, the (bool) dropout mask
                             + (e + 4)·a·s + 2·e·(a − k)·d         eager attention only: the fp32 softmax and its
                                                                   cast, k and v repeated to every head
      checkpointing on     A_layers = b·s·(e·h·L + 4h + B)         each layer's input, the final norm's fp32 input,
                                                                   and one layer re-run at a time
      checkpointing off    A_layers = b·s·(L·B + 4h)
      logits and loss      A_loss   = ρ·b·s·V·12                    fp32 logits, their log-softmax and its gradient,
                                                                   on the ρ labelled positions (``loss_only``)

  ``ρ`` (``answer_fraction``) defaults to 1: the worst case, every position an answer token. The tactile encoder's
  own activations (a few videos of 5 tokens) are left out. Checked against the tensors autograd saves in a small
  bf16 Qwen2 under autocast on the CPU (``tests/train/test_memory_plan.py``): ``B`` is an upper bound within 15%.

Sharding: DDP replicates everything; FSDP and DeepSpeed ZeRO-3 divide the frozen and trainable weights, the
gradients and the AdamW state by the world size; ZeRO-2 divides the gradients and the AdamW state only.
Activations are per GPU and never sharded. Not counted: the CUDA context and kernels (about 1 GB), DDP's and
DeepSpeed's communication buckets and the allocator's fragmentation; a plan that fills more than 90% of the GPU
is marked tight.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tacreasoner.model.encoder_config import TactileEncoderConfig

if TYPE_CHECKING:
    from tacreasoner.model.stages import LoraSettings

__all__ = ["ENGINES", "PRESETS", "MemoryPlan", "ModelShapes", "count_model", "layer_bytes_per_token",
           "plan_for_config", "plan_memory", "render_plans", "resolve_llm"]

ENGINES = ("ddp", "fsdp", "deepspeed-zero2", "deepspeed-zero3")
STAGES = (1, 2)
"""As :data:`tacreasoner.model.stages.STAGES` (kept here so checking arguments imports no torch)."""
SHARD_WEIGHTS = ("fsdp", "deepspeed-zero3")
"""Engines that shard the weights too (the others shard at most the gradients and the optimizer state)."""
GB = 1e9
TIGHT = 0.9
LOSS_BYTES = 12
"""Per labelled position and vocabulary row: fp32 logits, their saved log-softmax and the fp32 gradient."""
NEW_TOKENS = 5
"""Tokens ``prepare_tokenizer`` adds to a Qwen2.5 tokenizer (``<|tactile_pad|>`` and four reasoning tags); they fit
in Qwen2.5's spare embedding rows (151,665 tokens, 152,064 rows), so the vocabulary rows stay as configured."""

_QWEN25 = {"vocab_size": 152064, "tie_word_embeddings": False, "rms_norm_eps": 1e-6, "rope_theta": 1_000_000.0,
           "max_position_embeddings": 32768, "hidden_act": "silu", "dtype": "bfloat16"}
PRESETS: dict[str, dict[str, Any]] = {
    "qwen2.5-7b": {**_QWEN25, "hidden_size": 3584, "intermediate_size": 18944, "num_hidden_layers": 28,
                   "num_attention_heads": 28, "num_key_value_heads": 4},
    "qwen2.5-14b": {**_QWEN25, "hidden_size": 5120, "intermediate_size": 13824, "num_hidden_layers": 48,
                    "num_attention_heads": 40, "num_key_value_heads": 8},
}
"""Published Qwen2.5 sizes (Qwen2Config fields; the Instruct models share them), for plans without a download."""
_PRESET_NAMES = {"qwen2.5-7b": "Qwen2.5-7B", "qwen2.5-14b": "Qwen2.5-14B"}


@dataclass(frozen=True)
class ModelShapes:
    """What one stage's model holds, counted on the meta device: what the memory plan multiplies."""

    name: str
    stage: int
    parameters: int
    """Every parameter of the model the stage trains (LLM, tactile encoder, projector; PEFT's copies in Stage II)."""
    llm_parameters: int
    """The LLM's own parameters, before any adapter (Qwen2.5-7B: about 7.6 B)."""
    trainable: int
    trainable_parts: tuple[tuple[str, int], ...]
    weight_dtype: str
    frozen_bytes: int
    trainable_bytes: int
    gradient_bytes: int
    optimizer_bytes: int
    largest_block_bytes: int
    """The largest unit FSDP/ZeRO-3 gathers at once: one decoder layer, or the embedding or output matrix."""
    hidden_size: int
    layers: int
    heads: int
    head_dim: int
    kv_heads: int
    intermediate_size: int
    vocab_rows: int
    lora_elements: int
    """Per token and layer: Σ over the LoRA-adapted projections of (in_features + r) (0 outside Stage II)."""
    lora_mask_bytes: int
    """Per token and layer: Σ in_features of the LoRA-adapted projections when LoRA dropout is on (its masks)."""
    tied_embeddings: bool


@dataclass(frozen=True)
class MemoryPlan:
    """Bytes per GPU of one stage under one engine and world size (module docstring: what each term is)."""

    shapes: ModelShapes
    engine: str
    world_size: int
    gpu_gb: float
    batch_size: int
    max_length: int
    gradient_checkpointing: bool
    attention: str
    answer_fraction: float
    frozen_weights: float
    trainable_weights: float
    gradients: float
    optimizer: float
    gathered: float
    layer_activations: float
    loss_activations: float
    notes: tuple[str, ...] = ()

    @property
    def activations(self) -> float:
        return self.layer_activations + self.loss_activations

    @property
    def total(self) -> float:
        return (self.frozen_weights + self.trainable_weights + self.gradients + self.optimizer + self.gathered
                + self.activations)

    @property
    def share(self) -> float:
        """The total as a share of the GPU's memory."""
        return self.total / (self.gpu_gb * GB)

    @property
    def fits(self) -> bool:
        return self.share <= 1.0


# ------------------------------------------------------------------------------------------ the LLM's shape


def resolve_llm(llm: str | Path) -> tuple[str, Any]:
    """(display name, transformers config) of a preset name, a hub id of a preset (``Qwen/Qwen2.5-7B-Instruct``)
    or a local directory with ``config.json``: never a download."""
    from transformers import AutoConfig, Qwen2Config

    path = Path(llm)
    if path.is_dir():
        if not (path / "config.json").is_file():
            raise FileNotFoundError(f"{path}: no config.json (a model directory, or a preset: {', '.join(PRESETS)})")
        config = AutoConfig.from_pretrained(path)
        if getattr(config, "model_type", None) == "tacreasoner":  # a saved TacReasoner model: its LLM
            config = config.text_config
        return path.resolve().name, config
    key = re.sub(r"-instruct$", "", str(llm).lower().rsplit("/", 1)[-1])
    if key in PRESETS:
        return _PRESET_NAMES[key], Qwen2Config(**PRESETS[key])
    raise ValueError(f"LLM {str(llm)!r} is neither a local directory with config.json nor a known architecture "
                     f"({', '.join(PRESETS)}): pass --llm with one of those or a model directory")


def _dtype(name: str, text_config: Any) -> Any:
    import torch

    if name == "auto":
        name = str(getattr(text_config, "dtype", None) or getattr(text_config, "torch_dtype", None) or "float32")
    return getattr(torch, name.removeprefix("torch."))


def count_model(text_config: Any, *, stage: int = 2, lora: LoraSettings | None = None,
                encoder: TactileEncoderConfig | dict[str, Any] | None = None, dtype: str = "bfloat16",
                new_tokens: int = NEW_TOKENS, name: str = "LLM") -> ModelShapes:
    """Build the stage's model on the meta device as the trainer does and count what it holds.

    ``text_config``: a transformers config of the causal LM; ``new_tokens``: rows the tokenizer adds (trained in
    both stages); ``dtype``: ``model.dtype`` (``auto``: the LLM config's own)."""
    import torch
    from torch import nn

    from tacreasoner.model.configuration import TacReasonerConfig
    from tacreasoner.model.modeling import TacReasonerForCausalLM
    from tacreasoner.model.stages import LoraSettings, configure_stage
    from tacreasoner.train.trainer import master_weights_in_fp32

    if stage not in STAGES:
        raise ValueError(f"stage must be one of {', '.join(map(str, STAGES))}, got {stage!r}")
    lora = lora or LoraSettings()
    enc = encoder if isinstance(encoder, TactileEncoderConfig) else TactileEncoderConfig.from_dict(encoder)
    vocab = int(text_config.vocab_size)
    new_ids = list(range(max(vocab - new_tokens, 0), vocab))
    config = TacReasonerConfig(text_config=text_config.to_dict(), encoder=enc.to_dict(),
                               tactile_token_id=new_ids[0] if new_ids else 0, new_token_ids=new_ids)
    weight_dtype = _dtype(dtype, text_config)
    with torch.device("meta"):
        model = TacReasonerForCausalLM(config).to(weight_dtype)
    llm = model.language_model
    llm_parameters = sum(p.numel() for p in llm.parameters())
    embeddings, output = model.get_input_embeddings(), model.get_output_embeddings()  # before PEFT wraps them
    tied = isinstance(output, nn.Module) and getattr(output, "weight", None) is getattr(embeddings, "weight", None)
    vocab_rows = int(embeddings.weight.shape[0])
    block_bytes = [w.numel() * w.element_size() for w in (getattr(embeddings, "weight", None),
                                                           getattr(output, "weight", None)) if w is not None]
    trained = configure_stage(model, stage, lora)
    master_weights_in_fp32(trained, "bf16")  # as the trainer does: trainable parameters are fp32 master weights

    frozen = trainable = gradient = optimizer = count = 0
    parts: dict[str, int] = {}
    for param_name, p in trained.named_parameters():
        size = p.numel() * p.element_size()
        if not p.requires_grad:
            frozen += size
            continue
        count += p.numel()
        trainable += size
        gradient += size
        optimizer += p.numel() * (8 if p.dtype == torch.float32 else 12)
        part = _part(param_name, stage, lora)
        parts[part] = parts.get(part, 0) + p.numel()

    blocks = [m for m in llm.modules() if type(m).__name__ in (getattr(llm, "_no_split_modules", None) or [])]
    block_bytes += [sum(p.numel() * p.element_size() for p in m.parameters()) for m in blocks]

    lora_elements = lora_mask = 0
    if stage == 2:
        targets = set(lora.target_modules)
        adapted = [m for n, m in llm.named_modules() if n.rsplit(".", 1)[-1] in targets]
        layers = max(int(text_config.num_hidden_layers), 1)
        for module in adapted:
            base = getattr(module, "base_layer", module)
            in_features = int(getattr(base, "in_features", 0) or 0)
            lora_elements += in_features + lora.r
            lora_mask += in_features if lora.dropout > 0 else 0
        lora_elements, lora_mask = lora_elements // layers, lora_mask // layers

    hidden = int(text_config.hidden_size)
    heads = int(text_config.num_attention_heads)
    head_dim = int(getattr(text_config, "head_dim", None) or hidden // heads)
    return ModelShapes(
        name=name, stage=stage, parameters=sum(p.numel() for p in trained.parameters()),
        llm_parameters=llm_parameters, trainable=count,
        trainable_parts=tuple(sorted(parts.items(), key=lambda kv: -kv[1])),
        weight_dtype=str(weight_dtype).removeprefix("torch."), frozen_bytes=frozen, trainable_bytes=trainable,
        gradient_bytes=gradient, optimizer_bytes=optimizer, largest_block_bytes=max(block_bytes, default=0),
        hidden_size=hidden, layers=int(text_config.num_hidden_layers), heads=heads, head_dim=head_dim,
        kv_heads=int(getattr(text_config, "num_key_value_heads", None) or heads),
        intermediate_size=int(getattr(text_config, "intermediate_size", None) or 4 * hidden),
        vocab_rows=vocab_rows, lora_elements=lora_elements, lora_mask_bytes=lora_mask,
        tied_embeddings=bool(tied))


def _part(name: str, stage: int, lora: LoraSettings) -> str:
    """Which part of the model a trainable parameter belongs to, in words."""
    if "lora_" in name:
        return f"LoRA r {lora.r} on {'/'.join(lora.target_modules)}"
    if name.endswith(".rows"):
        return "new token rows"
    if "embed_tokens" in name or "lm_head" in name or "wte" in name:
        return "embeddings"
    if "projector" in name:
        return "projector"
    if "tactile_encoder" in name:
        return "tactile encoder"
    return "other"


# ------------------------------------------------------------------------------------------ the plan


def layer_bytes_per_token(shapes: ModelShapes, *, activation_bytes: int = 2, attention: str = "sdpa",
                          max_length: int = 1024) -> int:
    """``B`` of the module docstring: what one decoder layer keeps for the backward pass, per token."""
    e, h, d = activation_bytes, shapes.hidden_size, shapes.head_dim
    out = e * (4 * h + 2 * shapes.heads * d + 2 * shapes.kv_heads * d + 4 * shapes.intermediate_size)
    out += e * shapes.lora_elements + shapes.lora_mask_bytes
    if attention == "eager":
        out += (e + 4) * shapes.heads * max_length + 2 * e * (shapes.heads - shapes.kv_heads) * d
    return out


def plan_memory(shapes: ModelShapes, *, engine: str = "ddp", world_size: int = 1, batch_size: int = 8,
                max_length: int = 1024, gradient_checkpointing: bool = True, activation_bytes: int = 2,
                attention: str = "sdpa", answer_fraction: float = 1.0, gpu_gb: float = 80.0,
                notes: Sequence[str] = ()) -> MemoryPlan:
    """Bytes per GPU for ``shapes`` under ``engine`` on ``world_size`` GPUs (pure arithmetic; module docstring)."""
    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r} is not one of {', '.join(ENGINES)}")
    for what, value in (("world size", world_size), ("batch size", batch_size), ("max length", max_length)):
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{what} must be a whole number ≥ 1, got {value!r}")
    if not 0 < answer_fraction <= 1:
        raise ValueError(f"answer fraction must be in (0, 1], got {answer_fraction}")
    if not gpu_gb > 0:
        raise ValueError(f"GPU memory must be a positive number of GB, got {gpu_gb}")
    weights_over = world_size if engine in SHARD_WEIGHTS else 1
    states_over = world_size if engine != "ddp" else 1
    gathered = 2 * shapes.largest_block_bytes if weights_over > 1 else 0

    e, h = activation_bytes, shapes.hidden_size
    per_layer = layer_bytes_per_token(shapes, activation_bytes=e, attention=attention, max_length=max_length)
    tokens = batch_size * max_length
    if gradient_checkpointing:
        layers = tokens * (e * h * shapes.layers + 4 * h + per_layer)
    else:
        layers = tokens * (shapes.layers * per_layer + 4 * h)
    loss = answer_fraction * tokens * shapes.vocab_rows * LOSS_BYTES
    return MemoryPlan(
        shapes=shapes, engine=engine, world_size=world_size, gpu_gb=float(gpu_gb), batch_size=batch_size,
        max_length=max_length, gradient_checkpointing=gradient_checkpointing, attention=attention,
        answer_fraction=answer_fraction, frozen_weights=shapes.frozen_bytes / weights_over,
        trainable_weights=shapes.trainable_bytes / weights_over, gradients=shapes.gradient_bytes / states_over,
        optimizer=shapes.optimizer_bytes / states_over, gathered=gathered, layer_activations=layers,
        loss_activations=loss, notes=tuple(notes))


def plan_for_config(config: Any, *, stage: int = 2, engine: str = "ddp", world_sizes: Sequence[int] = (1,),
                    llm: str | Path | None = None, gpu_gb: float = 80.0,
                    answer_fraction: float = 1.0) -> list[MemoryPlan]:
    """One plan per world size for ``config`` (a :class:`~tacreasoner.train.config.TrainConfig`): its LLM (or
    ``llm``: a preset or a model directory), encoder, LoRA, dtype, batch size, ``max_length`` and checkpointing."""
    from tacreasoner.train.head_settings import with_head_settings

    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r} is not one of {', '.join(ENGINES)}")
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {', '.join(map(str, STAGES))}, got {stage!r}")
    for n in world_sizes:
        if n < 1:
            raise ValueError(f"world size must be at least 1, got {n}")
    name, text_config = resolve_llm(llm if llm is not None else config.model.llm)
    notes: list[str] = []
    encoder = TactileEncoderConfig.from_dict(with_head_settings(config.model.encoder))
    appearance = Path(config.model.appearance) if config.model.appearance else None
    if appearance is not None and (appearance / "config.json").is_file():
        from tacreasoner.model.appearance import read_appearance_config
        from tacreasoner.model.modeling import _with_appearance_of

        # read_appearance_config: a VideoMAE directory's config.json is no TactileEncoderConfig
        encoder = _with_appearance_of(encoder, read_appearance_config(appearance))
    elif appearance is not None:
        notes.append(f"appearance encoder: {appearance} not found, so its shape is the config's encoder settings "
                     f"(frozen and small beside the LLM either way)")
    new_tokens = NEW_TOKENS
    shapes = count_model(text_config, stage=stage, lora=config.lora, encoder=encoder, dtype=config.model.dtype,
                         new_tokens=new_tokens, name=name)
    settings = config.stage(stage)
    notes += _trainer_notes(config, shapes, stage, engine, settings)
    precision = config.runtime.mixed_precision
    activation_bytes = 2 if precision in ("auto", "bf16", "fp16") or shapes.weight_dtype in ("bfloat16", "float16") \
        else 4
    return [plan_memory(shapes, engine=engine, world_size=n, batch_size=_micro_batch(settings, stage, n),
                        max_length=config.data.max_length,
                        gradient_checkpointing=config.model.gradient_checkpointing,
                        activation_bytes=activation_bytes, attention=config.model.attn_implementation or "sdpa",
                        answer_fraction=answer_fraction, gpu_gb=gpu_gb, notes=notes) for n in world_sizes]


def _micro_batch(settings: Any, stage: int, processes: int) -> int:
    """Examples per GPU per micro-batch on ``processes`` GPUs, as the trainer derives it (from ``global_batch``
    where the config states one, refusing a launch it does not divide)."""
    derive = getattr(settings, "micro_batch", None)
    return derive(f"stage{stage}", processes) if derive is not None else settings.batch_size


def _trainer_notes(config: Any, shapes: ModelShapes, stage: int, engine: str, settings: Any) -> list[str]:
    """What the trainer refuses or does differently from what a plan might suggest."""
    notes = []
    if settings.skip:
        notes.append(f"stage{stage}.skip is true in this config: the trainer would skip this stage")
    if stage == 2 and engine == "fsdp" and shapes.tied_embeddings:
        notes.append("the trainer refuses FSDP in Stage II of a tied-embedding LLM: use ddp or deepspeed-zero2")
    if engine == "deepspeed-zero3":
        notes.append("the trainer refuses DeepSpeed ZeRO-3 (its final save does not gather partitioned weights): "
                     "use fsdp to shard the frozen LLM, or deepspeed-zero2")
    if engine.startswith("deepspeed") and settings.grad_accum != 1:
        notes.append(f"the trainer refuses grad_accum > 1 under DeepSpeed (this config: {settings.grad_accum}): "
                     f"--set stage{stage}.grad_accum=1")
    return notes


# ------------------------------------------------------------------------------------------ rendering


def _count(n: float) -> str:
    for unit, size in (("B", 1e9), ("M", 1e6), ("K", 1e3)):
        if n >= size:
            return f"{n / size:.2f} {unit}" if unit == "B" else f"{n / size:.1f} {unit}"
    return str(int(n))


def _column(plan: MemoryPlan) -> str:
    return f"{plan.engine} × {plan.world_size}"


def render_plans(plans: Sequence[MemoryPlan]) -> str:
    """One Markdown table, a column per plan (same model and stage; e.g. 1, 2 and 8 GPUs), then the notes."""
    if not plans:
        raise ValueError("no plans to render")
    first, shapes = plans[0], plans[0].shapes
    stage = "I" if shapes.stage == 1 else "II"
    parts = ", ".join(f"{what} {_count(n)}" for what, n in shapes.trainable_parts)
    lines = [
        f"{shapes.name}, Stage {stage}: {_count(shapes.parameters)} parameters (LLM {_count(shapes.llm_parameters)}), "
        f"{_count(shapes.trainable)} trainable ({parts})",
        f"weights {shapes.weight_dtype}; examples of {first.max_length} tokens, gradient checkpointing "
        f"{'on' if first.gradient_checkpointing else 'off'}, {first.attention} attention, logits on "
        f"{first.answer_fraction:.0%} of positions; trainable parameters, gradients and AdamW moments in fp32",
        "",
    ]
    rows: list[tuple[str, list[str]]] = [
        ("examples per GPU (micro-batch)", [str(p.batch_size) for p in plans]),
        ("frozen weights", [f"{p.frozen_weights / GB:.2f}" for p in plans]),
        ("trainable parameters", [f"{p.trainable_weights / GB:.2f}" for p in plans]),
        ("gradients", [f"{p.gradients / GB:.2f}" for p in plans]),
        ("AdamW state", [f"{p.optimizer / GB:.2f}" for p in plans]),
    ]
    if any(p.gathered for p in plans):
        rows.append(("gathered weights (FSDP/ZeRO-3)", [f"{p.gathered / GB:.2f}" for p in plans]))
    rows += [
        ("activations: layers", [f"{p.layer_activations / GB:.2f}" for p in plans]),
        ("activations: logits + loss", [f"{p.loss_activations / GB:.2f}" for p in plans]),
        ("**total**", [f"**{p.total / GB:.2f}**" for p in plans]),
        (f"fits {first.gpu_gb:g} GB?", [_verdict(p) for p in plans]),
    ]
    header = ["per GPU, GB", *(_column(p) for p in plans)]
    table = [header, *([label, *cells] for label, cells in rows)]
    widths = [max(len(row[i]) for row in table) for i in range(len(header))]
    lines.append("| " + " | ".join(c.ljust(w) for c, w in zip(header, widths, strict=True)) + " |")
    lines.append("|" + "|".join("-" * (w + 1) + ("-" if i == 0 else ":") for i, w in enumerate(widths)) + "|")
    for row in table[1:]:
        lines.append("| " + " | ".join(c.ljust(w) if i == 0 else c.rjust(w)
                                       for i, (c, w) in enumerate(zip(row, widths, strict=True))) + " |")
    notes = list(dict.fromkeys(n for p in plans for n in p.notes))
    notes.append("not counted: CUDA context (~1 GB), communication buckets, allocator fragmentation")
    lines += ["", *(f"- {n}" for n in notes)]
    return "\n".join(lines)


def _verdict(plan: MemoryPlan) -> str:
    if not plan.fits:
        return f"no ({plan.share:.0%})"
    return f"tight ({plan.share:.0%})" if plan.share > TIGHT else f"yes ({plan.share:.0%})"
