"""``TacReasonerForCausalLM``: a Hugging Face causal LM with tactile embeddings scattered into its input.

One readable file in the style of ``transformers``' LLaVA: each video in a prompt is a run of
``tokens_per_video`` placeholder ids (the processor expands ``<tactile>``); the encoder turns each
video into that many embeddings, and ``forward`` writes them over the placeholders' text embeddings
before calling the language model. Everything else (loss, KV cache, generation) is the LM's own.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, ClassVar

import torch
from torch import nn
from transformers import AutoModelForCausalLM, PreTrainedModel
from transformers.modeling_outputs import CausalLMOutputWithPast

from tacreasoner.model.configuration import TacReasonerConfig
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.heads.hook import build_heads
from tacreasoner.model.packing import PACKABLE_ATTENTION, pack_rows
from tacreasoner.model.processing import OPTION_MASK_OFFSET
from tacreasoner.model.tactile_encoder import DynamicTactileEncoder, TactileProjector
from tacreasoner.model.token_rows import TokenRows

__all__ = ["TacReasonerForCausalLM", "TacReasonerPreTrainedModel", "TactileAnswer", "count_videos"]


@dataclass
class TactileAnswer:
    """A generated reply split into its reasoning and answer (either ``None`` when the model left it out)."""

    text: str
    think: str | None
    answer: str | None


def count_videos(input_ids: torch.Tensor, tactile_token_id: int, tokens_per_video: int) -> torch.Tensor:
    """Videos per sample, from the placeholder runs in ``input_ids``; a clear error when runs are malformed."""
    per_sample = (input_ids == tactile_token_id).sum(dim=1)
    bad = per_sample % tokens_per_video != 0
    if bool(bad.any()):
        i = int(bad.nonzero()[0])
        raise ValueError(f"sample {i} holds {int(per_sample[i])} tactile placeholder tokens, not a multiple of "
                         f"tokens_per_video={tokens_per_video}: build inputs with TacReasonerProcessor, which expands "
                         f"each <tactile> to exactly that many")
    return per_sample // tokens_per_video


class TacReasonerPreTrainedModel(PreTrainedModel):
    config_class = TacReasonerConfig
    base_model_prefix = ""
    supports_gradient_checkpointing = True
    _supports_sdpa = True
    _supports_flash_attn = True
    _no_split_modules: ClassVar[list[str]] = ["DynamicTactileEncoder"]
    # No ties of its own; a dict (not None) makes PEFT collect the language model's (lm_head ↔ embed_tokens), so
    # trainable token rows in Stage II reach the tied output layer too.
    _tied_weights_keys: ClassVar[dict[str, str]] = {}

    def _init_weights(self, module: nn.Module) -> None:
        if getattr(module, "zero_init", False):
            for p in module.parameters(recurse=False):
                nn.init.zeros_(p)
            return
        super()._init_weights(module)


class TacReasonerForCausalLM(TacReasonerPreTrainedModel):
    """Tactile encoder + projector + any causal LM. See :mod:`tacreasoner.model` for the training stages."""

    def __init__(self, config: TacReasonerConfig, language_model: PreTrainedModel | None = None) -> None:
        super().__init__(config)
        if language_model is None:
            language_model = AutoModelForCausalLM.from_config(config.text_config)
        else:
            for module in language_model.modules():  # already trained: post_init must not re-initialise it
                module._is_hf_initialized = True
        self.language_model = language_model
        self.tactile_encoder = DynamicTactileEncoder(config.encoder_config, config.text_hidden_size)
        enc = self.encoder_config
        self.projector = TactileProjector(enc.hidden_size, config.text_hidden_size, enc.video_slots,
                                          build_heads(enc, config.text_hidden_size))
        self.post_init()

    # ------------------------------------------------------------------ HF plumbing
    def get_input_embeddings(self) -> nn.Module:
        return self.language_model.get_input_embeddings()

    def set_input_embeddings(self, value: nn.Module) -> None:
        self.language_model.set_input_embeddings(value)

    def get_output_embeddings(self) -> nn.Module | None:
        return self.language_model.get_output_embeddings()

    def set_output_embeddings(self, value: nn.Module) -> None:
        self.language_model.set_output_embeddings(value)

    @property
    def encoder_config(self) -> TactileEncoderConfig:
        return self.tactile_encoder.config

    def set_clip_reader(self, traits: tuple[str, ...] | list[str] = (), levels: int = 0) -> None:
        """Give the model an unfitted clip reader for ``traits`` (with at most ``levels`` levels each), or take it
        away (no traits). The reader is fitted when Stage II starts and does nothing before, so Stage II's config
        may decide it for any Stage I model."""
        traits = tuple(traits)
        current = self.projector.clip_reader
        if (current.traits if current is not None else ()) == traits and \
                (current is None or current.levels_per_trait == levels):
            return
        from tacreasoner.model.heads import ClipReader

        enc = self.encoder_config.replace(clip_reader=bool(traits), clip_reader_traits=traits,
                                          clip_reader_levels=levels if traits else 0)
        enc.validate()
        self.tactile_encoder.config = enc
        self.config.encoder = enc.to_dict()
        weight = self.projector.linear_1.weight
        self.projector.clip_reader = ClipReader(enc.hidden_size, enc.tokens_per_video, traits, levels).to(
            weight.device, weight.dtype) if traits else None

    # ------------------------------------------------------------------ building from parts
    @classmethod
    def from_llm(cls, llm: str | os.PathLike[str] | PreTrainedModel, *, tactile_token_id: int,
                 encoder: TactileEncoderConfig | dict | None = None, vocab_size: int | None = None,
                 new_token_ids: list[int] | None = None, appearance: str | os.PathLike[str] | None = None,
                 **llm_kwargs: Any) -> TacReasonerForCausalLM:
        """Wrap a trained causal LM (a directory, hub id, or model) — a real Qwen2.5 or the tiny one alike.

        ``vocab_size``: the tokenizer's size after tactile tokens were added; the LM's embeddings grow
        to it when smaller (new rows start at the mean of the old ones). Real checkpoints often have
        spare rows already (Qwen2.5: 152,064 rows for 151,665 tokens) and are left as they are. ``appearance``: a
        directory saved by ``AppearanceEncoder.save_pretrained`` (``pretrain-encoder``), holding a pretrained
        backbone (``tacreasoner encoder get``), or a Hugging Face VideoMAE directory, to load.
        """
        if not isinstance(llm, PreTrainedModel):
            llm = AutoModelForCausalLM.from_pretrained(llm, **llm_kwargs)
        if vocab_size is not None and vocab_size > llm.get_input_embeddings().num_embeddings:
            llm.resize_token_embeddings(vocab_size, mean_resizing=True)
        enc = encoder if isinstance(encoder, TactileEncoderConfig) else TactileEncoderConfig.from_dict(encoder)
        if appearance is not None:
            from tacreasoner.model.appearance import load_appearance

            loaded = load_appearance(appearance)
            enc = _with_appearance_of(enc, loaded.config)
        config = TacReasonerConfig(text_config=llm.config.to_dict(), encoder=enc.to_dict(),
                                   tactile_token_id=tactile_token_id, new_token_ids=new_token_ids or [])
        model = cls(config, language_model=llm)
        if appearance is not None:
            model.tactile_encoder.appearance.load_state_dict(loaded.state_dict())
        return model.to(llm.dtype)

    # ------------------------------------------------------------------ the tactile path
    def question_vectors(self, input_ids: torch.Tensor, text_embeds: torch.Tensor,
                         attention_mask: torch.Tensor | None, question_mask: torch.Tensor | None,
                         pretrained_only: bool = False) -> torch.Tensor:
        """Mean input embedding of each sample's question tokens (B×H), the temporal branch's steer.
        ``pretrained_only``: over the tokens the LLM came with (not ``new_token_ids``, whose rows Stage II trains),
        for the cross-video comparator, which is fitted when Stage II starts and must read its questions the same
        way at its end (with a tiny LLM most question tokens are new rows: the comparator misread 88 of 150 test
        attributes after Stage II; docs/training.md)."""
        if question_mask is None:  # fall back to every real, non-tactile token
            question_mask = input_ids != self.config.tactile_token_id
            if attention_mask is not None:
                question_mask = question_mask & attention_mask.bool()
        question_mask = question_mask > 0  # option names (values ≥ 2) are question tokens too
        if pretrained_only:
            question_mask = question_mask & self._pretrained(input_ids)
        weights = question_mask.to(text_embeds.dtype).unsqueeze(-1)
        return (text_embeds * weights).sum(1) / weights.sum(1).clamp(min=1.0)

    def _pretrained(self, input_ids: torch.Tensor) -> torch.Tensor:
        """Which ids are rows the LLM came with (not ``new_token_ids``)."""
        if not self.config.new_token_ids:
            return torch.ones_like(input_ids, dtype=torch.bool)
        return ~torch.isin(input_ids, torch.tensor(self.config.new_token_ids, device=input_ids.device))

    def option_vectors(self, input_ids: torch.Tensor, text_embeds: torch.Tensor,
                       question_mask: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor]:
        """Per prompt the mean embedding of each listed option's name over the LLM's own token rows (B×M×H, M the
        most options of a prompt; zeros past a prompt's count) and how many options it lists (B): what the
        cross-video layer matches the videos to ("(A) kitchen sponge (B) fake apple …", marked by the processor
        in ``question_mask``)."""
        if question_mask is None:
            return text_embeds.new_zeros(len(input_ids), 0, text_embeds.shape[-1]), \
                torch.zeros(len(input_ids), dtype=torch.long, device=input_ids.device)
        option = question_mask.long() - OPTION_MASK_OFFSET  # −1, −2 outside options
        counts = (option.max(1).values + 1).clamp(min=0)
        most = int(counts.max()) if len(counts) else 0
        pretrained = self._pretrained(input_ids)
        out = text_embeds.new_zeros(len(input_ids), most, text_embeds.shape[-1])
        for k in range(most):
            weights = ((option == k) & pretrained).to(text_embeds.dtype).unsqueeze(-1)
            out[:, k] = (text_embeds * weights).sum(1) / weights.sum(1).clamp(min=1.0)
        return out, counts

    def encode_videos(self, pixel_values: torch.Tensor, question: torch.Tensor | None = None,
                      sensor_ids: torch.Tensor | None = None, appearance: torch.Tensor | None = None,
                      slots: torch.Tensor | None = None, per_sample: torch.Tensor | None = None,
                      sample_question: torch.Tensor | None = None) -> torch.Tensor:
        """Videos → V×tokens_per_video×LLM-hidden embeddings (what replaces the placeholders).

        ``slots``: each video's position in its own prompt (0 for the first), for ``encoder.video_slots``;
        ``per_sample`` (videos per prompt) and ``sample_question`` (B×H), for ``encoder.cross_video``."""
        features = self.tactile_encoder(pixel_values, question, sensor_ids, appearance)
        features, _, _ = self.projector.heads.write(features, per_sample, sample_question)
        return self.projector(features, slots)

    def embed_inputs(self, input_ids: torch.Tensor, pixel_values: torch.Tensor | None = None,
                     attention_mask: torch.Tensor | None = None, question_mask: torch.Tensor | None = None,
                     sensor_ids: torch.Tensor | None = None, appearance_tokens: torch.Tensor | None = None,
                     ) -> torch.Tensor:
        """Text embeddings with each video's tactile embeddings written over its placeholder run."""
        return self._embed(input_ids, pixel_values, attention_mask, question_mask, sensor_ids, appearance_tokens)[0]

    def tactile_features(self, input_ids: torch.Tensor, pixel_values: torch.Tensor | None,
                         attention_mask: torch.Tensor | None, question_mask: torch.Tensor | None,
                         sensor_ids: torch.Tensor | None, appearance_tokens: torch.Tensor | None = None,
                         ) -> tuple[torch.Tensor, torch.Tensor | None, torch.Tensor, torch.Tensor | None,
                                    tuple[torch.Tensor, torch.Tensor] | None]:
        """The text embeddings, the tactile encoder's output (V×tokens_per_video×hidden, None without videos), each
        prompt's number of videos, and the cross-video layer's question vector and listed options
        (:meth:`option_vectors`; None without the layer): what the projector gets."""
        tpv = self.encoder_config.tokens_per_video
        per_sample = count_videos(input_ids, self.config.tactile_token_id, tpv)
        n_placeholders, n_videos = int(per_sample.sum()), 0 if pixel_values is None else len(pixel_values)
        if n_placeholders != n_videos:
            raise ValueError(f"the prompts hold {n_placeholders} tactile placeholder(s) "
                             f"({n_placeholders * tpv} tokens at {tpv} per video) but {n_videos} video(s) were given")
        text_embeds = self.get_input_embeddings()(input_ids)
        if n_videos == 0:
            return text_embeds, None, per_sample, None, None
        question = compared = options = None
        if self.encoder_config.use_temporal and self.encoder_config.question_conditioning:
            question = self.question_vectors(input_ids, text_embeds, attention_mask, question_mask)
            question = question.repeat_interleave(per_sample, dim=0)
        if self.encoder_config.cross_video:
            compared = self.question_vectors(input_ids, text_embeds, attention_mask, question_mask,
                                             pretrained_only=True)
            options = self.option_vectors(input_ids, text_embeds, question_mask)
        features = self.tactile_encoder(pixel_values.to(text_embeds.dtype), question, sensor_ids, appearance_tokens)
        return text_embeds, features, per_sample, compared, options

    def _embed(self, input_ids: torch.Tensor, pixel_values: torch.Tensor | None, attention_mask: torch.Tensor | None,
               question_mask: torch.Tensor | None, sensor_ids: torch.Tensor | None,
               appearance_tokens: torch.Tensor | None, video_winner: torch.Tensor | None = None,
               readings: dict[str, torch.Tensor] | None = None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """:meth:`embed_inputs` plus the cross-video comparator's loss against ``video_winner`` (None without);
        ``readings``: the read-out heads' verdicts made elsewhere (``heads.base.READINGS``), used instead of theirs."""
        text_embeds, features, per_sample, compared, options = self.tactile_features(
            input_ids, pixel_values, attention_mask, question_mask, sensor_ids, appearance_tokens)
        if features is None:
            return text_embeds, None
        slots = None
        if self.projector.video_slot is not None:  # each video's place in its own prompt: 0, 1, … per sample
            first = (per_sample.cumsum(0) - per_sample).repeat_interleave(per_sample)
            slots = torch.arange(len(features), device=input_ids.device) - first
        heads = self.projector.heads
        features, comparison_loss, places = heads.write(features, per_sample, compared, options, video_winner,
                                                        readings)
        tactile = self.projector(features, slots)
        mask = (input_ids == self.config.tactile_token_id).unsqueeze(-1)
        embeds = text_embeds.masked_scatter(mask, tactile.to(text_embeds.dtype).reshape(-1, text_embeds.shape[-1]))
        if question_mask is not None:
            embeds = heads.mark(embeds, question_mask.long() - OPTION_MASK_OFFSET, places)
        return embeds, comparison_loss

    # ------------------------------------------------------------------ forward / generate
    def forward(self, input_ids: torch.Tensor | None = None, attention_mask: torch.Tensor | None = None,
                pixel_values: torch.Tensor | None = None, sensor_ids: torch.Tensor | None = None,
                question_mask: torch.Tensor | None = None, labels: torch.Tensor | None = None,
                position_ids: torch.Tensor | None = None, past_key_values: Any = None,
                inputs_embeds: torch.Tensor | None = None, use_cache: bool | None = None,
                appearance_tokens: torch.Tensor | None = None, video_winner: torch.Tensor | None = None,
                readings: dict[str, torch.Tensor] | None = None, loss_only: bool = False, pack: bool = False,
                **kwargs: Any) -> CausalLMOutputWithPast:
        """``loss_only`` (with ``labels``): the LM head and its softmax run on the labelled positions only and
        no logits are returned: the same loss and gradients for a fraction of the work where prompts and
        padding outnumber answer tokens (training; benchmarks/results/train_speed.md). ``pack`` (with
        ``loss_only``): the LM runs on packed rows without padding and with the prefix every sample shares computed
        once (:mod:`tacreasoner.model.packing`): again the same loss and gradients, for fewer positions.
        ``appearance_tokens`` (optional, V×tokens_per_video×hidden): cached output of the frozen ViT.
        ``video_winner`` (optional, B or B×3): per prompt the place of the video its comparison picks, and
        optionally the index of its attribute in ``encoder.cross_video_attributes`` and whether it asks for more (1)
        or less (0) (−100: none); with
        ``encoder.cross_video`` and labels, the comparator's cross-entropy × ``encoder.cross_video_loss`` joins the
        loss. ``readings`` (optional): the read-out heads' verdicts made elsewhere, written instead of their own:
        Stage II trains on out-of-fold readings (``heads.crossfit``; keys in ``heads.base.READINGS``)."""
        comparison_loss = None
        if inputs_embeds is None:
            if input_ids is None:
                raise ValueError("give input_ids (from TacReasonerProcessor) or inputs_embeds")
            inputs_embeds, comparison_loss = self._embed(input_ids, pixel_values, attention_mask, question_mask,
                                                         sensor_ids, appearance_tokens, video_winner, readings)
        elif pixel_values is not None:
            raise ValueError("pixel_values need input_ids to find the placeholders; got inputs_embeds instead")
        if past_key_values is not None:  # passed on only when given: newer transformers call it `cache` and warn
            kwargs["past_key_values"] = past_key_values
        if loss_only and labels is not None and kwargs.get("past_key_values", kwargs.get("cache")) is None:
            shareable = None
            if pack and input_ids is not None:  # only plain token rows may be shared, never a clip's or a mark's
                shareable = input_ids != self.config.tactile_token_id
                if question_mask is not None:
                    shareable &= question_mask == 0
            out = self._labelled_loss(inputs_embeds, attention_mask, position_ids, labels, pack=pack,
                                      shareable=shareable, **kwargs)
        else:
            out = self.language_model(inputs_embeds=inputs_embeds, attention_mask=attention_mask, labels=labels,
                                      position_ids=position_ids, use_cache=use_cache, **kwargs)
        if comparison_loss is not None and out.loss is not None:
            out.loss = out.loss + self.encoder_config.cross_video_loss * comparison_loss.to(out.loss.dtype)
        return out

    def _labelled_loss(self, inputs_embeds: torch.Tensor, attention_mask: torch.Tensor | None,
                       position_ids: torch.Tensor | None, labels: torch.Tensor,
                       num_items_in_batch: torch.Tensor | float | None = None, pack: bool = False,
                       shareable: torch.Tensor | None = None, **kwargs: Any) -> CausalLMOutputWithPast:
        """The causal LM loss of ``transformers`` (next-token cross-entropy, −100 ignored, summed over
        ``num_items_in_batch`` or averaged) with the LM head applied to the labelled positions only; ``pack``: on
        packed rows where the batch and the attention allow it."""
        lm = self.language_model
        targets = nn.functional.pad(labels, (0, 1), value=-100)[:, 1:]
        packed = None
        if pack and attention_mask is not None and position_ids is None and \
                lm.config._attn_implementation in PACKABLE_ATTENTION:
            packed = pack_rows(inputs_embeds, attention_mask, targets, shareable)
        if packed is not None:
            inputs_embeds, attention_mask = packed.inputs_embeds, packed.attention_mask
            position_ids, targets = packed.position_ids, packed.targets
        hidden = lm.get_decoder()(inputs_embeds=inputs_embeds, attention_mask=attention_mask,
                                  position_ids=position_ids, use_cache=False, **kwargs).last_hidden_state
        keep = targets != -100
        logits = self._head(hidden[keep]).float()
        loss = nn.functional.cross_entropy(logits, targets[keep], reduction="sum")
        if num_items_in_batch is None:
            loss = loss / keep.sum().clamp(min=1)
        else:
            loss = loss / (num_items_in_batch.to(loss.device) if torch.is_tensor(num_items_in_batch)
                           else num_items_in_batch)
        return CausalLMOutputWithPast(loss=loss)

    def _head(self, hidden: torch.Tensor) -> torch.Tensor:
        """The LM head. Under CPU autocast a frozen output matrix is cast once and kept (re-cast when it changes)
        rather than at every step: the same logits, without a 49k x 576 copy per step for SmolLM2 (20-80 ms in
        profiles; benchmarks/results/step_time_ab.md)."""
        head = self.language_model.get_output_embeddings()
        base = head.base if isinstance(head, TokenRows) else head
        device = hidden.device.type
        if not (device == "cpu" and torch.is_autocast_enabled(device) and isinstance(base, nn.Linear)
                and base.bias is None and not base.weight.requires_grad):
            return head(hidden)
        dtype, weight = torch.get_autocast_dtype(device), base.weight
        cached = self.__dict__.get("_cast_head")  # (matrix, its version, the cast): not a parameter or buffer
        if cached is None or cached[0] is not weight or cached[1] != weight._version or cached[2].dtype != dtype:
            cached = self.__dict__["_cast_head"] = (weight, weight._version, weight.detach().to(dtype))
        with torch.autocast(device, enabled=False):
            out = nn.functional.linear(hidden.to(dtype), cached[2])
        return head.with_new_columns(hidden, out) if isinstance(head, TokenRows) else out

    @torch.no_grad()
    def generate(self, input_ids: torch.Tensor, attention_mask: torch.Tensor | None = None,
                 pixel_values: torch.Tensor | None = None, sensor_ids: torch.Tensor | None = None,
                 question_mask: torch.Tensor | None = None, labels: torch.Tensor | None = None,
                 appearance_tokens: torch.Tensor | None = None, **generate_kwargs: Any) -> torch.Tensor:
        """The LM's own ``generate`` (KV cache, greedy/sampling, streamers) on the tactile-filled prompt.

        ``appearance_tokens``: the clips' frozen appearance tokens computed earlier (as in :meth:`forward`).
        Returns only the new token ids (B×new); :meth:`answer` decodes and splits them.
        """
        embeds = self.embed_inputs(input_ids, pixel_values, attention_mask, question_mask, sensor_ids,
                                   appearance_tokens)
        return self.language_model.generate(inputs_embeds=embeds, attention_mask=attention_mask, **generate_kwargs)

    def answer(self, processor: Any, question: str, videos: list[Any], *, system: str | None = None,
               max_new_tokens: int = 256, do_sample: bool = False, temperature: float = 0.7, top_p: float = 0.9,
               streamer: Any = None) -> TactileAnswer:
        """Ask one question about ``videos`` (clips, frames or paths; one per ``<tactile>``) and parse the reply."""
        from tacreasoner.tasks.extract import split_reasoning

        inputs = processor.prompt(question, videos, system=system).to(self.device)
        sampling: dict[str, Any] = {"do_sample": False}
        if do_sample:
            sampling = {"do_sample": True, "temperature": temperature, "top_p": top_p}
        out = self.generate(**inputs, max_new_tokens=max_new_tokens, streamer=streamer,
                            eos_token_id=processor.eos_token_ids, pad_token_id=processor.tokenizer.pad_token_id,
                            **sampling)
        text = processor.tokenizer.decode(out[0], skip_special_tokens=True)
        think, answer = split_reasoning(text)
        return TactileAnswer(text=text, think=think, answer=answer)


def _with_appearance_of(enc: TactileEncoderConfig, appearance: TactileEncoderConfig) -> TactileEncoderConfig:
    """The wanted encoder config with the pre-trained appearance ViT's shape fields."""
    shape_fields = ("num_frames", "image_size", "backbone", "backbone_layer", "patch_size", "tubelet_size",
                    "hidden_size", "num_layers", "num_heads", "mlp_ratio", "layer_norm_eps", "qkv_bias")
    return enc.replace(**{f: getattr(appearance, f) for f in shape_fields})
