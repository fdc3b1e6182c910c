"""A teacher that is a local Hugging Face causal LM (a directory, or a hub id where a hub is reachable).

For users who distil from an open model on their own GPU instead of paying for an API. Generation runs in
a worker thread (``asyncio.to_thread``) so the async pipeline keeps writing samples while the model works,
and one generation at a time (a model is not safe to drive from two threads, and batching is not worth
its padding logic for a teacher pass). Weights load from safetensors only (never unpickled).
"""

from __future__ import annotations

import asyncio
import threading
from typing import Any

from tacreasoner.cot.schema import CoTJob, Prompt, TeacherReply
from tacreasoner.cot.teacher import TeacherConfig, UsageMeter

_LOAD_OPTIONS = ("device", "dtype", "seed", "trust_remote_code")
"""``extra`` keys read at load time; every other ``extra`` key is passed to ``model.generate``."""
_KEEP = ("<think>", "</think>", "<answer>", "</answer>")
_DTYPES = ("auto", "float32", "float16", "bfloat16")


class HFTeacher:
    """Local causal-LM teacher; ``config.model`` is the checkpoint directory or hub id."""

    name = "hf"

    def __init__(self, config: TeacherConfig) -> None:
        try:
            import torch
            import transformers
        except ImportError:
            raise ImportError("the hf teacher needs torch and transformers: pip install 'tacreasoner[train]'") from None
        if not config.model.strip():
            raise ValueError("teacher: the hf backend needs a model (a local directory or hub id)")
        extra = dict(config.extra)
        device = str(extra.get("device") or ("cuda" if torch.cuda.is_available() else "cpu"))
        dtype_name = str(extra.get("dtype") or ("auto" if device.startswith("cuda") else "float32"))
        if dtype_name not in _DTYPES:
            raise ValueError(f"teacher: extra.dtype must be one of {', '.join(_DTYPES)}, got {dtype_name!r}")
        dtype: Any = dtype_name if dtype_name == "auto" else getattr(torch, dtype_name)
        if "seed" in extra:
            transformers.set_seed(int(extra["seed"]))
        trust = bool(extra.get("trust_remote_code", False))
        self.config = config
        self.model = config.model
        self.usage = UsageMeter()
        self.device = device
        self._gen_options = {k: v for k, v in extra.items() if k not in _LOAD_OPTIONS}
        try:
            self._tokenizer = transformers.AutoTokenizer.from_pretrained(config.model, trust_remote_code=trust)
            dtype_kw = "dtype" if _version(transformers.__version__) >= (4, 56) else "torch_dtype"
            self._model = transformers.AutoModelForCausalLM.from_pretrained(
                config.model, use_safetensors=True, trust_remote_code=trust, **{dtype_kw: dtype})
        except (OSError, ValueError) as exc:
            raise ValueError(f"teacher: cannot load a causal LM from {config.model!r}: "
                             f"{' '.join(str(exc).split())[:300]}") from None
        self._model.to(device)
        self._model.eval()
        self._thread_lock = threading.Lock()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._lock: asyncio.Lock | None = None

    def _loop_lock(self) -> asyncio.Lock:
        """An asyncio lock of the running loop, so waiting callers queue on the loop, not in worker threads
        (the thread lock inside still guards the model if two loops ever share this teacher)."""
        loop = asyncio.get_running_loop()
        if self._loop is not loop or self._lock is None:
            self._loop, self._lock = loop, asyncio.Lock()
        return self._lock

    async def generate(self, job: CoTJob, prompt: Prompt) -> TeacherReply:
        async with self._loop_lock():
            text, n_prompt, n_new, truncated = await asyncio.to_thread(self._generate_sync, prompt)
        self.usage.record_attempt("ok")
        self.usage.record_tokens(n_prompt, n_new, 0.0)
        if truncated:
            self.usage.record_truncated()
        return TeacherReply(text=text, model=self.model, prompt_tokens=n_prompt, completion_tokens=n_new,
                            cost_usd=0.0, attempts=1)

    def prompt_ids(self, prompt: Prompt) -> Any:
        """Input ids: the tokenizer's chat template when it has one, else a plain role-labelled prompt."""
        tok = self._tokenizer
        if getattr(tok, "chat_template", None):
            messages = [{"role": "system", "content": prompt.system}] if prompt.system.strip() else []
            messages.append({"role": "user", "content": prompt.user})
            encoded = tok.apply_chat_template(messages, add_generation_prompt=True, tokenize=True,
                                              return_tensors="pt", return_dict=True)
            return encoded["input_ids"]
        text = f"System: {prompt.system}\nUser: {prompt.user}\nAssistant:"
        return tok(text, return_tensors="pt")["input_ids"]

    def _generate_sync(self, prompt: Prompt) -> tuple[str, int, int, bool]:
        import torch

        tok = self._tokenizer
        with self._thread_lock, torch.inference_mode():
            input_ids = self.prompt_ids(prompt).to(self.device)
            options: dict[str, Any] = {"max_new_tokens": self.config.max_tokens,
                                       "do_sample": self.config.temperature > 0}
            if options["do_sample"]:
                options["temperature"] = self.config.temperature
            pad = tok.pad_token_id if tok.pad_token_id is not None else tok.eos_token_id
            if pad is not None:
                options["pad_token_id"] = pad
            options.update(self._gen_options)
            output = self._model.generate(input_ids=input_ids, attention_mask=torch.ones_like(input_ids), **options)
        new = output[0, input_ids.shape[1]:]
        eos = tok.eos_token_id
        truncated = len(new) >= options["max_new_tokens"] and (eos is None or int(new[-1]) != eos)
        text = tok.decode(new, skip_special_tokens=False)
        for special in getattr(tok, "all_special_tokens", []):
            if special not in _KEEP:  # some reasoning models register <think> as a special token: keep tags
                text = text.replace(special, "")
        return text, int(input_ids.shape[1]), len(new), truncated


def _version(text: str) -> tuple[int, ...]:
    parts = []
    for piece in text.split(".")[:2]:
        digits = "".join(ch for ch in piece if ch.isdigit())
        parts.append(int(digits or 0))
    return tuple(parts)
