"""Train a few rows of an LLM's (input and output) embeddings without training the matrices.

Stage I must teach the LLM the tokens added for touch (``<tactile>``, the reasoning tags) and nothing else in its
vocabulary. A gradient mask on the whole matrix does that but gives the optimizer, the gradients and the
all-reduce vocabulary-sized tensors (1.09 B parameters for Qwen2.5-7B, to learn five rows), and FSDP's sharded
parameters drop the mask. Here the rows live in their own small parameter: the frozen matrix answers every other
id, the ``rows`` table answers the new ones, and :func:`merge_token_rows` writes them back before saving, so a
saved model is a plain LLM again.

A tied LLM (SmolLM2, the tiny LLM) shares one ``rows`` table between input and output, as it shares the matrix.

Stage II trains the rows the same way; its adapter folder (LoRA, PEFT's format) gets them in ``token_rows.safetensors``
(:func:`save_token_rows`), which :func:`load_token_rows` writes into a Stage I model before the adapter goes on.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch
from torch import nn

__all__ = ["ROWS_FILE", "TokenRows", "load_token_rows", "merge_token_rows", "save_token_rows", "train_token_rows"]

ROWS_FILE = "token_rows.safetensors"


class TokenRows(nn.Module):
    """``base`` (an ``nn.Embedding``, or the ``nn.Linear`` output layer) with rows ``ids`` read from ``rows``.

    ``base`` stays frozen and untouched until :meth:`merged`; ``rows`` starts as a copy of its rows, so wrapping
    changes no output.
    """

    def __init__(self, base: nn.Module, ids: list[int], rows: nn.Parameter | None = None) -> None:
        super().__init__()
        if not isinstance(base, nn.Embedding | nn.Linear):
            raise TypeError(f"TokenRows wraps an nn.Embedding or nn.Linear, got {type(base).__name__}")
        self.base = base
        unique = sorted(set(ids))
        if not unique or unique[0] < 0 or unique[-1] >= base.weight.shape[0]:
            raise ValueError(f"token rows {unique[:5]}… must be in [0, {base.weight.shape[0]}) and not empty")
        ids_t = torch.tensor(unique, dtype=torch.long, device=base.weight.device)
        self.register_buffer("ids", ids_t, persistent=False)
        lookup = torch.full((base.weight.shape[0],), -1, dtype=torch.long, device=base.weight.device)
        lookup[ids_t] = torch.arange(len(ids_t), device=base.weight.device)
        self.register_buffer("lookup", lookup, persistent=False)
        self.rows = rows if rows is not None else nn.Parameter(base.weight.detach()[ids_t].clone())
        if tuple(self.rows.shape) != (len(ids_t), base.weight.shape[1]):
            raise ValueError(f"rows have shape {tuple(self.rows.shape)}, expected {(len(ids_t), base.weight.shape[1])}")

    @property
    def weight(self) -> torch.Tensor:
        """The frozen matrix (what ties, shapes and dtype checks read); the new rows are in ``rows``."""
        return self.base.weight

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out = self.base(x)
        if isinstance(self.base, nn.Embedding):  # ids → vectors: swap in the new rows where x is a new id
            place = self.lookup[x]
            new = self.rows.to(out.dtype)[place.clamp(min=0)]
            return torch.where((place >= 0).unsqueeze(-1), new, out)
        return self.with_new_columns(x, out)

    def with_new_columns(self, x: torch.Tensor, out: torch.Tensor) -> torch.Tensor:
        """The output layer's ``out = base(x)`` with the new ids' columns recomputed from ``rows``."""
        new = nn.functional.linear(x, self.rows.to(x.dtype),
                                   None if self.base.bias is None else self.base.bias[self.ids])
        return out.index_copy(-1, self.ids, new.to(out.dtype))

    @torch.no_grad()
    def merged(self) -> nn.Module:
        """``base`` with the trained rows written in (its dtype): the plain module to put back."""
        self.base.weight[self.ids] = self.rows.detach().to(self.base.weight.dtype)
        return self.base


def train_token_rows(language_model: nn.Module, ids: list[int]) -> list[nn.Parameter]:
    """Wrap ``language_model``'s input and output embeddings so only rows ``ids`` train; returns the new parameters.

    Call on a frozen model; an already wrapped one is merged first (configuring a stage twice is harmless).
    """
    merge_token_rows(language_model)
    inputs, outputs = language_model.get_input_embeddings(), language_model.get_output_embeddings()
    wrapped_in = TokenRows(inputs, ids)
    language_model.set_input_embeddings(wrapped_in)
    params = [wrapped_in.rows]
    if outputs is not None and isinstance(outputs, nn.Embedding | nn.Linear):
        tied = outputs.weight is inputs.weight
        wrapped_out = TokenRows(outputs, ids, wrapped_in.rows if tied else None)
        language_model.set_output_embeddings(wrapped_out)
        if not tied:
            params.append(wrapped_out.rows)
    for p in params:
        p.requires_grad_(True)
    return params


def merge_token_rows(language_model: nn.Module) -> bool:
    """Write trained rows back into the matrices and unwrap them (before saving, or to undo); True if any were."""
    found = False
    inputs, outputs = language_model.get_input_embeddings(), language_model.get_output_embeddings()
    if isinstance(outputs, TokenRows):
        language_model.set_output_embeddings(outputs.merged())
        found = True
    if isinstance(inputs, TokenRows):
        language_model.set_input_embeddings(inputs.merged())
        found = True
    return found


def save_token_rows(language_model: nn.Module, directory: str | os.PathLike[str]) -> bool:
    """Write the trained rows (and their ids) to ``directory/token_rows.safetensors``; False if none are wrapped."""
    from safetensors.torch import save_file

    inputs, outputs = language_model.get_input_embeddings(), language_model.get_output_embeddings()
    if not isinstance(inputs, TokenRows):
        return False
    tensors = {"ids": inputs.ids.detach().cpu(), "input_rows": inputs.rows.detach().cpu().contiguous()}
    if isinstance(outputs, TokenRows) and outputs.rows is not inputs.rows:
        tensors["output_rows"] = outputs.rows.detach().cpu().contiguous()
    Path(directory).mkdir(parents=True, exist_ok=True)
    save_file(tensors, str(Path(directory) / ROWS_FILE))
    return True


@torch.no_grad()
def load_token_rows(language_model: nn.Module, directory: str | os.PathLike[str]) -> bool:
    """Write rows saved by :func:`save_token_rows` into ``language_model``'s matrices; False if there is no file."""
    from safetensors.torch import load_file

    file = Path(directory) / ROWS_FILE
    if not file.is_file():
        return False
    saved = load_file(str(file))
    ids = saved["ids"].long()
    targets = [(language_model.get_input_embeddings(), saved["input_rows"])]
    outputs = language_model.get_output_embeddings()
    if "output_rows" in saved:
        targets.append((outputs, saved["output_rows"]))
    for module, rows in targets:
        weight = module.weight
        if rows.shape != (len(ids), weight.shape[1]) or int(ids.max()) >= weight.shape[0]:
            raise ValueError(f"{file}: rows of shape {tuple(rows.shape)} for ids up to {int(ids.max())} do not fit "
                             f"an embedding of shape {tuple(weight.shape)} (saved for another LLM?)")
        weight[ids.to(weight.device)] = rows.to(weight.device, weight.dtype)
    return True
