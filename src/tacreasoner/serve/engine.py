"""One loaded model answering requests: streamed token by token, one at a time, or several at once in a batch.

This is the Python API behind ``tacreasoner ask``, the OpenAI-compatible server and the demo::

    engine = TactileEngine.load("runs/quickstart/train/seed0/stage2/model")
    for piece in engine.stream(Prompt.ask("Is <tactile> soft?", ["clip.mp4"])):
        print(piece.text, end="")          # Delta: reasoning, then the answer
    reply = engine.complete(Prompt.ask("Is <tactile> soft?", ["clip.mp4"]))   # Reply: think, answer, usage

Generation runs in a worker thread (transformers' ``generate``) that pushes token ids into a queue; the caller's
thread decodes them, splits reasoning from answer, applies stop strings, and can cancel. A request's faults (wrong
placeholder count, unreadable video, an over-long prompt) are :class:`RequestError`; the server turns them into
4xx answers.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from transformers import StoppingCriteria, StoppingCriteriaList
from transformers.generation.streamers import BaseStreamer

from tacreasoner.evaluate.predict import REPLY_TOKENS
from tacreasoner.serve.stream import Delta, ReasoningSplitter, StopMatcher, split_channels
from tacreasoner.tasks.schema import PLACEHOLDER

__all__ = ["MIN_CLIP_FRAMES", "DecodeTimeout", "Prompt", "Reply", "RequestError", "Sampling", "TactileEngine",
           "check_clip_length"]

MIN_CLIP_FRAMES = 2
"""The fewest frames a clip may have. The model reads a touch from how the gel changes: each sampled frame minus the
clip's first frame (the gel at rest), and the temporal branch's frame differences. One frame holds no change at all
(its background-subtracted input is blank), so a still image or a one-frame clip would be answered from nothing;
the video processor repeats frames to fill its ``num_frames``, so two distinct frames are enough to read."""


class RequestError(ValueError):
    """The request cannot be answered as asked (the client's fault); ``param`` names the offending field."""

    def __init__(self, message: str, *, param: str | None = None, code: str = "invalid_request") -> None:
        super().__init__(message)
        self.param = param
        self.code = code


class DecodeTimeout(RuntimeError):
    """Decoding ran past the request's deadline; the partial reply is attached."""

    def __init__(self, seconds: float, partial: Reply | None = None) -> None:
        super().__init__(f"decoding took longer than the {seconds:g} s limit")
        self.partial = partial


@dataclass(frozen=True)
class Sampling:
    """How to decode. ``temperature`` 0 is greedy (the default: answers are reproducible); ``seed`` makes sampling
    reproducible too."""

    max_new_tokens: int = REPLY_TOKENS
    temperature: float = 0.0
    top_p: float = 1.0
    seed: int | None = None
    stop: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.max_new_tokens < 1:
            raise RequestError(f"max_tokens must be at least 1, got {self.max_new_tokens}", param="max_tokens")
        if not 0.0 <= self.temperature <= 2.0:
            raise RequestError(f"temperature must be in [0, 2], got {self.temperature}", param="temperature")
        if not 0.0 < self.top_p <= 1.0:
            raise RequestError(f"top_p must be in (0, 1], got {self.top_p}", param="top_p")

    @property
    def greedy(self) -> bool:
        return self.temperature == 0.0

    def batch_key(self) -> tuple[Any, ...] | None:
        """Requests with the same key can share one ``generate`` call; None: this one runs alone (a seeded sample
        must not depend on what else is in the batch)."""
        if self.greedy:
            return ("greedy",)
        return None if self.seed is not None else ("sample", self.temperature, self.top_p)


@dataclass(frozen=True)
class Prompt:
    """Chat turns (``role``/``content``; user text holds one ``<tactile>`` per video, in order) and the videos:
    paths, T×H×W×3 uint8 frames or clips."""

    messages: tuple[dict[str, str], ...]
    videos: tuple[Any, ...] = ()

    @classmethod
    def ask(cls, question: str, videos: Sequence[Any] = (), system: str | None = None) -> Prompt:
        turns = ({"role": "system", "content": system},) if system else ()
        return cls((*turns, {"role": "user", "content": question}), tuple(videos))

    @property
    def placeholders(self) -> int:
        return sum(m["content"].count(PLACEHOLDER) for m in self.messages if m["role"] == "user")


@dataclass
class Reply:
    """A finished answer. ``finish_reason``: ``stop`` (end of turn or a stop string) or ``length`` (max tokens)."""

    text: str
    reasoning: str
    content: str
    finish_reason: str
    prompt_tokens: int
    completion_tokens: int
    timings: dict[str, float] = field(default_factory=dict)
    asked_as: str | None = None
    """The wording the model was asked in where it differs from the user's (a person's question asked again in the
    benchmark's words: ``serve.stepwise``)."""

    def to_dict(self) -> dict[str, Any]:
        return {"think": self.reasoning or None, "answer": self.content or None, "text": self.text,
                "finish_reason": self.finish_reason,
                "usage": {"prompt_tokens": self.prompt_tokens, "completion_tokens": self.completion_tokens},
                "timings": self.timings, **({"asked_as": self.asked_as} if self.asked_as else {})}


def check_clip_length(n_frames: int, where: str, param: str | None = None) -> None:
    """A clip shorter than :data:`MIN_CLIP_FRAMES` is the client's fault (a still image sent as a video, say)."""
    if n_frames < MIN_CLIP_FRAMES:
        still = " (a still image?)" if n_frames == 1 else ""
        raise RequestError(f"{where}: the clip has {n_frames} frame{'s' if n_frames != 1 else ''}{still}; at least "
                           f"{MIN_CLIP_FRAMES} are needed, since a touch is read from how the gel changes between "
                           f"frames", param=param, code="video_too_short")


@dataclass
class _Prepared:
    """One prompt's row (ids, question mask, videos), ready for ``processor.collate`` alone or with others."""

    row: dict[str, Any]
    prepare_s: float = 0.0
    """Seconds spent preparing it (decoding the videos, tokenising), wherever that happened: reported in timings."""

    @property
    def prompt_tokens(self) -> int:
        return len(self.row["input_ids"])


def _long_enough(video: Any, k: int) -> Any:
    """The video, checked to have :data:`MIN_CLIP_FRAMES` frames; a path becomes a clip (probed, not decoded: the
    processor decodes it as it would the path)."""
    from tacreasoner.data.clip import TactileClip
    from tacreasoner.data.readers import read_video_clip

    if isinstance(video, str | os.PathLike):
        video = read_video_clip(Path(video))
    if isinstance(video, TactileClip):
        n = video.n_frames if video.n_frames is not None else len(video.frames)
    elif isinstance(video, np.ndarray) and video.ndim == 4:
        n = len(video)
    else:
        return video  # not frames: the processor says what is wrong with it
    check_clip_length(n, f"video {k}", "messages")
    return video


class _TokenQueue(BaseStreamer):
    """Receives new token ids from ``generate`` (batch of one) in its thread; the first push is the prompt."""

    def __init__(self) -> None:
        self.queue: queue.Queue[list[int] | None] = queue.Queue()
        self._prompt_seen = False

    def put(self, value: torch.Tensor) -> None:
        if not self._prompt_seen:
            self._prompt_seen = True
            return
        self.queue.put([int(v) for v in value.reshape(-1).tolist()])

    def end(self) -> None:
        self.queue.put(None)


class _Halt(StoppingCriteria):
    """Stops ``generate`` when asked (stop string seen, client gone) or at the deadline."""

    def __init__(self, deadline: float | None) -> None:
        self.deadline = deadline
        self.requested = False
        self.timed_out = False

    def __call__(self, input_ids: torch.Tensor, scores: torch.Tensor, **kwargs: Any) -> torch.Tensor:
        if self.deadline is not None and time.monotonic() > self.deadline:
            self.timed_out = True
        stop = self.requested or self.timed_out
        return torch.full((input_ids.shape[0],), stop, dtype=torch.bool, device=input_ids.device)


class TactileEngine:
    """A saved TacReasoner model and its processor, ready to answer. Calls are serialised by a lock: one
    ``generate`` at a time uses all cores better than several fighting over them."""

    def __init__(self, model: Any, processor: Any, *, name: str = "tacreasoner",
                 max_prompt_tokens: int | None = None) -> None:
        self.model = model
        self.processor = processor
        self.name = name
        self._base = getattr(model, "get_base_model", lambda: model)()
        self.device = next(self._base.parameters()).device
        limit = getattr(getattr(self._base.config, "text_config", None), "max_position_embeddings", None)
        self.max_prompt_tokens = max_prompt_tokens or limit
        self.lock = threading.Lock()

    @classmethod
    def load(cls, model_dir: str | os.PathLike[str], *, device: str | None = None, name: str | None = None,
             dtype: str | None = None) -> TactileEngine:
        """A model saved by ``tacreasoner train`` (``…/stage2/model``), its weights cast to ``dtype`` (float32 or
        bfloat16; as saved when None); a clear error when the folder is not one."""
        from tacreasoner.evaluate.predict import load_trained

        path = Path(model_dir)
        if not (path / "config.json").is_file():
            raise FileNotFoundError(f"{path}: not a saved TacReasoner model (no config.json); give the `model` folder "
                                    f"a training run wrote, e.g. runs/quickstart/train/seed0/stage2/model")
        model, processor = load_trained(path, device=device, dtype=dtype)
        return cls(model, processor, name=name or "tacreasoner")

    # ------------------------------------------------------------------ preparing
    def prepare(self, prompt: Prompt) -> _Prepared:
        """Token ids, masks and preprocessed videos of one prompt; :class:`RequestError` for the client's faults."""
        start = time.perf_counter()
        if prompt.placeholders != len(prompt.videos):
            raise RequestError(f"the messages hold {prompt.placeholders} {PLACEHOLDER} placeholder(s) but "
                               f"{len(prompt.videos)} video(s) were given: one {PLACEHOLDER} per video",
                               param="messages", code="placeholder_mismatch")
        try:
            enc = self.processor.encode_conversation(list(prompt.messages), add_generation_prompt=True)
            clips = [_long_enough(v, k) for k, v in enumerate(prompt.videos, 1)]
            videos = self.processor.preprocess_videos(clips)
        except RequestError:
            raise
        except (ValueError, FileNotFoundError) as exc:
            raise RequestError(str(exc).splitlines()[0], param="messages") from exc
        if self.max_prompt_tokens and len(enc.input_ids) >= self.max_prompt_tokens:
            raise RequestError(f"the prompt is {len(enc.input_ids)} tokens; this model reads at most "
                               f"{self.max_prompt_tokens}", param="messages", code="context_length_exceeded")
        return _Prepared({"input_ids": enc.input_ids, "question_mask": enc.question_mask, **videos},
                         prepare_s=time.perf_counter() - start)

    def _generate_kwargs(self, sampling: Sampling, max_new_tokens: int, halt: _Halt) -> dict[str, Any]:
        kwargs: dict[str, Any] = {"max_new_tokens": max_new_tokens, "eos_token_id": self.processor.eos_token_ids,
                                  "pad_token_id": self.processor.tokenizer.pad_token_id,
                                  "stopping_criteria": StoppingCriteriaList([halt])}
        if sampling.greedy:
            kwargs["do_sample"] = False
        else:
            kwargs.update(do_sample=True, temperature=sampling.temperature, top_p=sampling.top_p)
        return kwargs

    def _room(self, prepared: _Prepared, wanted: int) -> int:
        """New tokens that still fit the model's context after the prompt."""
        if not self.max_prompt_tokens:
            return wanted
        return max(1, min(wanted, self.max_prompt_tokens - prepared.prompt_tokens))

    # ------------------------------------------------------------------ one request, streamed
    def stream(self, prompt: Prompt | _Prepared, sampling: Sampling | None = None, *,
               timeout_s: float | None = None, cancelled: threading.Event | None = None,
               ) -> Iterator[Delta | Reply]:
        """Deltas as the reply grows, then the finished :class:`Reply`. :class:`DecodeTimeout` when decoding
        outlasts ``timeout_s``; setting ``cancelled`` stops decoding early (a client that went away)."""
        sampling = sampling or Sampling()
        prepared = prompt if isinstance(prompt, _Prepared) else self.prepare(prompt)
        ready = time.perf_counter()
        halt = _Halt(None if timeout_s is None else time.monotonic() + timeout_s)
        tokens = _TokenQueue()
        failure: list[BaseException] = []
        eos = set(self.processor.eos_token_ids)

        def run() -> None:
            try:
                with self.lock, torch.inference_mode():
                    if sampling.seed is not None:
                        torch.manual_seed(sampling.seed)
                    batch = self.processor.collate([prepared.row], padding_side="left")
                    inputs = {k: v.to(self.device) for k, v in batch.items()}
                    self._base.generate(**inputs, streamer=tokens, **self._generate_kwargs(
                        sampling, self._room(prepared, sampling.max_new_tokens), halt))
            except BaseException as exc:  # re-raised in the caller's thread
                failure.append(exc)
                tokens.end()

        worker = threading.Thread(target=run, name="tacreasoner-generate", daemon=True)
        worker.start()
        ids: list[int] = []
        shown = ""
        stopper = StopMatcher(sampling.stop)
        splitter = ReasoningSplitter()
        finish = "length"
        first_token: float | None = None

        def advance(text: str, ended: bool) -> Iterator[Delta]:
            """Show what of ``text`` no stop string can still claim (all of it once the reply ``ended``)."""
            nonlocal shown, finish
            safe, stopped = stopper.push(text)
            if stopped:
                finish, halt.requested = "stop", True
            elif ended:
                safe = text  # nothing is held back for a stop string any more
            if len(safe) > len(shown):
                yield from splitter.feed(safe[len(shown):])
                shown = safe

        try:
            while (new := tokens.queue.get()) is not None:
                first_token = first_token or time.perf_counter()
                if finish == "stop":  # ended (end of turn or a stop string): drain what generate still pushes
                    continue
                if cancelled is not None and cancelled.is_set():
                    halt.requested = True
                for token in new:
                    if token in eos:
                        finish, halt.requested = "stop", True
                        break
                    ids.append(token)
                text = self.processor.tokenizer.decode(ids, skip_special_tokens=True)
                if text.endswith("\ufffd") and finish != "stop":  # half a multi-byte character: wait for the rest
                    continue
                yield from advance(text, finish == "stop")
        finally:
            halt.requested = True
            worker.join()
        if failure:
            raise failure[0]
        if finish != "stop":  # length, deadline or cancel: what was held back (a half character, a stop prefix)
            yield from advance(self.processor.tokenizer.decode(ids, skip_special_tokens=True), True)
        yield from splitter.finish()
        done = time.perf_counter()
        reply = self._reply(shown, finish, prepared.prompt_tokens, len(ids), prepared.prepare_s, ready, first_token,
                            done)
        if halt.timed_out:
            raise DecodeTimeout(timeout_s or 0.0, reply)
        yield reply

    def complete(self, prompt: Prompt | _Prepared, sampling: Sampling | None = None, *,
                 timeout_s: float | None = None) -> Reply:
        """The whole reply at once (the stream, consumed)."""
        reply = None
        for piece in self.stream(prompt, sampling, timeout_s=timeout_s):
            reply = piece
        assert isinstance(reply, Reply)
        return reply

    # ------------------------------------------------------------------ several requests, batched
    def complete_batch(self, prompts: Sequence[Prompt | _Prepared], samplings: Sequence[Sampling], *,
                       timeout_s: float | None = None) -> list[Reply]:
        """Several requests in one ``generate`` call (left-padded). Their samplings must share a
        :meth:`Sampling.batch_key`; each keeps its own ``max_new_tokens`` and ``stop``."""
        if len(prompts) == 1 and len(samplings) == 1:
            return [self.complete(prompts[0], samplings[0], timeout_s=timeout_s)]
        keys = {s.batch_key() for s in samplings}
        if len(prompts) != len(samplings) or len(keys) != 1 or None in keys:
            raise ValueError("complete_batch: one sampling per prompt, all with the same batch_key (not None)")
        prepared = [p if isinstance(p, _Prepared) else self.prepare(p) for p in prompts]
        start = time.perf_counter()
        batch = dict(self.processor.collate([p.row for p in prepared], padding_side="left"))
        ready = time.perf_counter()
        wanted = max(self._room(p, s.max_new_tokens) for p, s in zip(prepared, samplings, strict=True))
        halt = _Halt(None if timeout_s is None else time.monotonic() + timeout_s)
        with self.lock, torch.inference_mode():
            new = self._base.generate(**{k: v.to(self.device) for k, v in batch.items()},
                                      **self._generate_kwargs(samplings[0], wanted, halt))
        done = time.perf_counter()
        eos = set(self.processor.eos_token_ids)
        replies = []
        for p, s, row in zip(prepared, samplings, new.tolist(), strict=True):
            limit = self._room(p, s.max_new_tokens)
            ids, finish = [], "length"
            for token in row[:limit]:
                if token in eos:
                    finish = "stop"
                    break
                ids.append(token)
            text = self.processor.tokenizer.decode(ids, skip_special_tokens=True)
            safe, stopped = StopMatcher(s.stop).push(text)
            if stopped:
                text, finish = safe, "stop"
            replies.append(self._reply(text, finish, p.prompt_tokens, len(ids), p.prepare_s + ready - start, ready,
                                       None, done))
        if halt.timed_out:
            raise DecodeTimeout(timeout_s or 0.0, None)
        return replies

    @staticmethod
    def _reply(text: str, finish: str, prompt_tokens: int, completion_tokens: int, prepare_s: float, ready: float,
               first_token: float | None, done: float) -> Reply:
        """``prepare_s``: seconds the prompt took to get ready (decoding, tokenising, batching), ending at ``ready``,
        whether it was prepared here or earlier by the server's worker (waiting in the queue is not counted)."""
        reasoning, content = split_channels(text)
        decode_s = done - ready
        timings = {"prepare_s": round(prepare_s, 4), "decode_s": round(decode_s, 4),
                   "total_s": round(prepare_s + decode_s, 4),
                   "tokens_per_s": round(completion_tokens / decode_s, 2) if decode_s > 0 else 0.0}
        if first_token is not None:
            timings["first_token_s"] = round(prepare_s + first_token - ready, 4)
        return Reply(text=text.strip(), reasoning=reasoning, content=content, finish_reason=finish,
                     prompt_tokens=prompt_tokens, completion_tokens=completion_tokens, timings=timings)
