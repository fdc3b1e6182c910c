"""The cross-video layer and two read-out heads it holds: the comparator and the name matcher.

One attention layer lets the videos of one prompt see each other; the comparator (which video the question picks)
and the name matcher (which video is which listed option) are benchmark-specific read-outs fitted on the frozen
encoder's features when Stage II starts (:class:`ComparatorHead`, :class:`NameMatcherHead`: the interface of
:mod:`tacreasoner.model.heads.base`). Which attributes the comparator knows comes from the config
(``encoder.cross_video_attributes``), never from the benchmark's vocabulary.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import torch
from torch import nn
from torch.nn import functional as F

from tacreasoner.model.fitting import as_loud_as_a_token, ridge_solve
from tacreasoner.model.heads.base import HeadRows

__all__ = ["FIT_STEPS", "ComparatorFit", "ComparatorHead", "CrossVideoFusion", "NameMatcherHead", "fit_comparators"]

FIT_STEPS = 1500
"""AdamW steps of a comparator fit (its directions); read when a fit starts, so tests that check where and when
the comparator is fitted, not how well, may lower it."""


class CrossVideoFusion(nn.Module):
    """One attention layer over all the videos of one prompt, plus a comparator that says which video the question
    picks, written into every token of the prompt's videos.

    Each video is otherwise encoded alone, and a small LLM reads several videos' tokens as one blurred average
    (``VideoSlots``); yet a linear read-out of the tokens orders two objects far better than the LLM does
    (benchmarks/results/tactile_readout.md). Here the tokens of a prompt's 2..``max_videos`` videos, each with its
    place embedding, and the question vector as one more token, pass one transformer layer. A score per video (its
    standardised tokens along the direction of the attribute the question names, signed by its comparative, both
    read from the question vector) gives a distribution over the videos ("which is softer?"); its expectation over
    per-place verdict vectors is added to every token, so the LLM reads the verdict the way it reads one video's
    feel, by attending to all tactile tokens. The comparator is fitted on fixed features when Stage II starts
    (:meth:`fit`, which also makes the verdict vectors as loud as a token) and frozen; with
    ``encoder.cross_video_loss`` it also trains against the gold pick, attribute and comparative in Stage I
    (``winner``). Until then what the layer adds goes through zero-initialised maps, so single-video prompts and
    an untrained layer leave tokens unchanged. It sits in the projector, so the layer trains in both stages.
    """

    def __init__(self, hidden: int, heads: int, mlp_ratio: float, max_videos: int, question_dim: int,
                 tokens_per_video: int, attributes: int = 1) -> None:
        super().__init__()
        self.place = nn.Parameter(torch.randn(max_videos, hidden) * 0.02)
        self.verdict = nn.Parameter(torch.zeros(max_videos, hidden))
        self.question = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, hidden))
        self.layer = nn.TransformerEncoderLayer(hidden, heads, dim_feedforward=int(hidden * mlp_ratio), dropout=0.0,
                                                activation="gelu", batch_first=True, norm_first=True)
        width = tokens_per_video * hidden
        # the comparator: which attribute and which way the question asks (read from the question vector), one
        # direction per attribute over a video's standardised tokens (benchmarks/results/comparator_probe.md)
        self.attribute = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, attributes))
        self.comparative = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, 1))
        self.directions = nn.Parameter(torch.zeros(attributes, width))
        self.register_buffer("feature_mean", torch.zeros(width))
        self.register_buffer("feature_var", torch.ones(width))
        # the matcher: a video's features → its name's (standardised) embedding; one verdict per assignment
        self.names = nn.Linear(width, question_dim)
        self.register_buffer("name_mean", torch.zeros(question_dim))
        self.register_buffer("name_std", torch.ones(question_dim))
        self.register_buffer("names_fitted", torch.zeros(max_videos + 1, dtype=torch.bool))
        self._permutations = {k: list(itertools.permutations(range(k))) for k in range(2, max_videos + 1)}
        # one vector per (video place, option): an assignment writes the sum of its pairs' vectors
        self.assignments = nn.Parameter(torch.zeros(max_videos, max_videos, hidden))
        self.out = nn.Linear(hidden, hidden)
        self.out.zero_init = True  # read by the model's _init_weights too
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)

    @property
    def max_videos(self) -> int:
        return len(self.place)

    @property
    def question_dim(self) -> int:
        return self.attribute[0].normalized_shape[0]

    def _standardised(self, videos: torch.Tensor) -> torch.Tensor:
        """Per-dimension standardisation (as the probe's); the statistics follow the features only while the
        comparator trains by gradient (``encoder.cross_video_loss``), :meth:`fit` sets them exactly."""
        if self.training and self.directions.requires_grad:
            with torch.no_grad():
                flat = videos.detach().flatten(0, -2).float()
                self.feature_mean.lerp_(flat.mean(0), 0.01)
                self.feature_var.lerp_(flat.var(0, unbiased=False) if len(flat) > 1 else self.feature_var, 0.01)
        return self._normalised(videos)

    def _normalised(self, videos: torch.Tensor) -> torch.Tensor:
        return (videos - self.feature_mean.to(videos.dtype)) / (self.feature_var.to(videos.dtype) + 1e-5).sqrt()

    def _compare(self, videos: torch.Tensor, asked: torch.Tensor
                 ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """videos S×k×W (standardised), asked S×Dq → each video's score (S×k: its features along the direction of
        the attribute asked, signed by the comparative, more: +, less: −), the attribute logits and the
        comparative's logit (more). The attribute and the way are discrete choices: a blend of directions, mapped
        from the question, fitted the train questions but not unseen objects (comparator_probe.md)."""
        attribute_logits, more_logit = self.attribute(asked), self.comparative(asked).squeeze(-1)
        attribute, sign = self._chosen_direction(attribute_logits, more_logit)
        return self._scores(videos, attribute, sign), attribute_logits, more_logit

    @staticmethod
    def _chosen_direction(attribute_logits: torch.Tensor, more_logit: torch.Tensor
                          ) -> tuple[torch.Tensor, torch.Tensor]:
        """Per question the attribute it asks (its direction's index) and the comparative's sign (S×1)."""
        return attribute_logits.argmax(-1), torch.where(more_logit >= 0, 1.0, -1.0).to(more_logit.dtype).unsqueeze(-1)

    def _scores(self, videos: torch.Tensor, attribute: torch.Tensor, sign: torch.Tensor) -> torch.Tensor:
        """videos S×k×W (standardised) along each prompt's signed direction: S×k scores."""
        return _along(videos, sign * self.directions.to(videos.dtype)[attribute])

    @staticmethod
    def _comparison_loss(scores: torch.Tensor, attribute_logits: torch.Tensor, more_logit: torch.Tensor,
                         gold: torch.Tensor) -> tuple[torch.Tensor, int]:
        """Summed cross-entropies of the pick, the attribute and the comparative where ``gold`` (S or S×3) knows
        them, and the number of prompts with a pick."""
        if gold.ndim == 1:
            gold = torch.stack([gold, torch.full_like(gold, -100), torch.full_like(gold, -100)], dim=1)
        loss = scores.new_zeros((), dtype=torch.float32)
        valid, named, way = gold[:, 0] >= 0, gold[:, 1] >= 0, gold[:, 2] >= 0
        if bool(valid.any()):
            loss = loss + F.cross_entropy(scores[valid].float(), gold[valid, 0], reduction="sum")
        if bool(named.any()):
            loss = loss + F.cross_entropy(attribute_logits[named].float(), gold[named, 1], reduction="sum")
        if bool(way.any()):
            loss = loss + F.binary_cross_entropy_with_logits(more_logit[way].float(), gold[way, 2].float(),
                                                             reduction="sum")
        return loss, int(valid.sum())

    @property
    def comparator_parameters(self) -> list[nn.Parameter]:
        """What :meth:`fit` and :meth:`fit_names` set and freeze (the verdicts stay trainable)."""
        return [*self.attribute.parameters(), *self.comparative.parameters(), self.directions,
                *self.names.parameters()]

    def _match(self, videos: torch.Tensor, options: torch.Tensor) -> torch.Tensor:
        """videos S×k×W (raw, flattened), options S×k×Dq → per prompt the index (in ``_permutations[k]``) of the
        assignment (video v ↔ option p[v]) whose summed fit of each video's predicted name to its option's name
        is largest."""
        k = videos.shape[1]
        predicted = self.names(videos.to(self.names.weight.dtype))  # S×k×Dq
        wanted = (options.to(predicted.dtype) - self.name_mean.to(predicted.dtype)) / self.name_std.to(predicted.dtype)
        fit = predicted @ wanted.transpose(1, 2)  # S×k videos×k options
        index = torch.tensor(self._permutations[k], device=videos.device)  # P×k
        totals = fit[:, torch.arange(k, device=videos.device), index].sum(-1)  # S×P
        return totals.argmax(-1)

    def fit_names(self, videos: list[torch.Tensor], options: list[torch.Tensor], assignments: torch.Tensor,
                  penalty: float = 100.0, seed: int = 0) -> dict[str, float]:
        """Fit the matcher on prompts listing as many named options as they hold videos (OSC), then freeze it.

        ``videos``: per prompt its k×N×H encoder output; ``options``: per prompt its k×Dq option-name vectors
        (``option_vectors``); ``assignments``: per prompt the gold option index of each video (S×k). A ridge
        regression (closed form) maps a video's flattened features to the standardised embedding of its name;
        a prompt then gets the assignment whose videos' predicted names best fit its options. On the frozen
        encoder's features this matched held-out objects to their names where the LLM alone stayed at chance
        (docs/training.md). Returns the share of these prompts it assigns right."""
        if not videos:
            raise ValueError("the name matcher needs at least one prompt with named options to fit")
        if len(videos) != len(options) or len(videos) != len(assignments):
            raise ValueError(f"got {len(videos)} prompts' videos, {len(options)} option lists, "
                             f"{len(assignments)} assignments")
        for v, o, a in zip(videos, options, assignments, strict=True):
            if not (len(v) == len(o) == len(a)) or len(v) not in self._permutations:
                raise ValueError(f"each prompt needs as many options as videos (2..{self.max_videos}), got "
                                 f"{len(v)} videos, {len(o)} options, {len(a)} assigned")
        x = torch.cat([v.flatten(1) for v in videos]).float()
        y = torch.cat([o[a] for o, a in zip(options, assignments, strict=True)]).float()  # each video's own name
        with torch.no_grad():
            self.name_mean.copy_(y.mean(0))
            self.name_std.copy_(y.std(0, unbiased=False) + 1e-6)
            weight, bias = ridge_solve(x, (y - self.name_mean) / self.name_std, penalty)
            self.names.weight.copy_(weight.to(self.names.weight.dtype))
            self.names.bias.copy_(bias.to(self.names.bias.dtype))
            self.names_fitted.zero_()
            for v in videos:
                self.names_fitted[len(v)] = True
            generator = torch.Generator().manual_seed(seed + 1)
            self.assignments.copy_(as_loud_as_a_token(x, self.assignments.shape, generator))
        for p in self.names.parameters():
            p.requires_grad_(False)
        right = 0
        with torch.no_grad():
            for v, o, a in zip(videos, options, assignments, strict=True):
                chosen = self._permutations[len(v)][int(self._match(v.flatten(1)[None], o[None])[0])]
                right += int(list(chosen) == [int(i) for i in a])
        return {"named": len(videos), "assigned": right / len(videos)}

    def fit(self, videos: list[torch.Tensor], questions: torch.Tensor, targets: torch.Tensor,
            steps: int | None = None, lr: float = 1e-2, weight_decay: float = 0.1, batch_size: int = 16,
            seed: int = 0) -> dict[str, float]:
        """Fit the comparator on fixed features, then freeze it: a pick learnt jointly with the LLM's loss drowns
        that loss and does not learn to pick (docs/training.md), while on the frozen encoder's features the same
        comparator, fitted alone, orders unseen objects (benchmarks/results/comparator_probe.md).

        ``videos``: per prompt its k×N×H encoder output (k ≥ 2); ``questions``: S×Dq question vectors;
        ``targets``: S×3 gold pick, attribute index, more (1) / less (0). The two heads that read the attribute and
        the way from the question are ridge regressions (closed form); the directions are fitted by AdamW on the
        picks (``steps``, default :data:`FIT_STEPS`). Returns the fitted comparator's accuracy on these prompts (pick,
        attribute read, comparative read). :func:`fit_comparators` fits several comparators (cross-fitting's copies)
        in one loop, each as this would."""
        return fit_comparators([ComparatorFit(self, videos, questions, targets, seed)], steps=steps, lr=lr,
                               weight_decay=weight_decay, batch_size=batch_size)[0]

    def _prepare_fit(self, job: ComparatorFit) -> _Prepared:
        """Set the standardisation statistics and the ridge heads, zero the directions; what the descent reads."""
        videos, questions, targets = job.videos, job.questions, job.targets
        if not videos:
            raise ValueError("the comparator needs at least one comparison to fit")
        if len(videos) != len(questions) or len(videos) != len(targets):
            raise ValueError(f"got {len(videos)} prompts' videos, {len(questions)} questions, {len(targets)} targets")
        dtype = self.directions.dtype
        flat = torch.cat([v.flatten(1) for v in videos]).float()
        with torch.no_grad():
            self.feature_mean.copy_(flat.mean(0))
            self.feature_var.copy_(flat.var(0, unbiased=False))
            self.directions.zero_()
            named, way = targets[:, 1] >= 0, targets[:, 2] >= 0
            if bool(named.any()):
                _ridge(self.attribute, questions[named], F.one_hot(targets[named, 1], self.directions.shape[0]))
            if bool(way.any()):
                _ridge(self.comparative, questions[way], targets[way, 2:3] * 2.0 - 1.0)
            # the attribute and comparative heads are fixed from here, so each prompt's attribute and sign are read
            # once; only the pick's cross-entropy moves the directions (the arithmetic of _compare)
            asked = questions.to(dtype)
            attribute, sign = self._chosen_direction(self.attribute(asked), self.comparative(asked).squeeze(-1))
            width = max(len(v) for v in videos)
            feats = torch.zeros(len(videos), width, flat.shape[1], dtype=dtype)
            present = torch.zeros(len(videos), width, dtype=torch.bool)
            for i, v in enumerate(videos):
                feats[i, :len(v)] = self._normalised(v.flatten(1).to(dtype))
                present[i, :len(v)] = True
        for p in self.comparator_parameters:
            p.requires_grad_(False)
        return _Prepared(feats, present, attribute, sign.squeeze(-1), targets[:, 0].long(), flat,
                         torch.Generator().manual_seed(job.seed))

    def _finish_fit(self, job: ComparatorFit, prepared: _Prepared) -> dict[str, float]:
        """Start the verdict as loud as a token (it stayed at 3% of one, unread, from zero); the fit's accuracy."""
        with torch.no_grad():
            self.verdict.copy_(as_loud_as_a_token(prepared.flat, self.verdict.shape, prepared.generator))
        gold = job.targets
        with torch.no_grad():  # the prepared features: standardised, padded past a prompt's videos
            scores, attribute_logits, more_logit = self._compare(prepared.feats,
                                                                 job.questions.to(self.directions.dtype))
            scores = scores.masked_fill(~prepared.present, float("-inf"))
            right = {"pick": int((scores.argmax(-1) == gold[:, 0]).sum()),
                     "attribute": int((attribute_logits.argmax(-1) == gold[:, 1]).sum()),
                     "comparative": int(((more_logit > 0).long() == gold[:, 2]).sum())}
        n = len(job.videos)
        return {"comparisons": n, **{k: v / n for k, v in right.items()}}

    def forward(self, tokens: torch.Tensor, per_sample: torch.Tensor, question: torch.Tensor | None,
                winner: torch.Tensor | None = None, places: torch.Tensor | None = None,
                pick: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """tokens V×N×H (all prompts' videos in order), per_sample B (videos per prompt), question B×Dq or None,
        winner B or B×3: per prompt the gold pick's place, and optionally the attribute's index and whether the
        question asks for more (1) or less (0); −100 where unknown; places: the matcher's assignment (:meth:`places`,
        B×M). A prompt it matched gets that assignment, the others the comparator's pick; ``pick`` (B×max videos):
        the comparator's scores made elsewhere (training's out-of-fold readings), used for the verdict in place of
        this comparator's own (which still gives the loss). Returns the
        tokens and the comparator's loss: the mean over prompts with a pick of its cross-entropy, plus those of the
        attribute and the comparative where known (None when the batch has no pick)."""
        counts = per_sample.tolist()
        if max(counts, default=0) > self.max_videos:
            raise ValueError(f"a prompt holds {max(counts)} videos but the cross-video layer was built for at most "
                             f"{self.max_videos} (encoder.cross_video={self.max_videos})")
        starts = [sum(counts[:i]) for i in range(len(counts))]
        out = tokens.clone()
        n, hidden = tokens.shape[1], tokens.shape[2]
        loss_sum, picks = tokens.new_zeros(()), 0
        for k in sorted({c for c in counts if c >= 2}):  # prompts with the same number of videos go together
            samples = [i for i, c in enumerate(counts) if c == k]
            index = torch.tensor([starts[i] + j for i in samples for j in range(k)], device=tokens.device)
            group = tokens[index].view(len(samples), k, n, hidden) + self.place[:k, None].to(tokens.dtype)
            seq = group.flatten(1, 2)
            asked = question[samples] if question is not None else tokens.new_zeros(len(samples), self.question_dim)
            q = self.question(asked.to(tokens.dtype))  # S×H: what the question asks about, and which way
            seq = torch.cat([q.unsqueeze(1), seq], dim=1)
            mixed = self.layer(seq)[:, -k * n:]
            videos = self._standardised(tokens[index].view(len(samples), k, n * hidden))
            scores, attribute_logits, more_logit = self._compare(videos, asked.to(tokens.dtype))
            read = scores if pick is None else pick[samples, :k].to(scores.dtype)
            verdict = read.softmax(-1) @ self.verdict[:k].to(tokens.dtype)  # S×H
            matched = (places[samples, :1] >= 0).any(-1) if places is not None else None
            if matched is not None and bool(matched.any()):  # these ask which video is which option, not which wins
                verdict = verdict.clone()
                pairs = places[samples][matched][:, :k].argsort(-1)  # the option of each place
                verdict[matched] = self.assignment_verdict(pairs).to(verdict.dtype)
            delta = self.out(mixed - seq[:, -k * n:]) + verdict.unsqueeze(1)
            out[index] = tokens[index] + delta.reshape(len(samples) * k, n, hidden)
            if winner is not None:
                loss, count = self._comparison_loss(scores, attribute_logits, more_logit, winner[samples])
                loss_sum, picks = loss_sum + loss, picks + count
        return out, (loss_sum / picks if picks else None)

    def places(self, tokens: torch.Tensor, per_sample: torch.Tensor,
               options: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        """B×M: for each listed option of each prompt the place of the video the fitted matcher assigns it (−1 where
        the prompt is not matched: fewer or more options than videos, or no fitted matcher for that many)."""
        vectors, listed = options[0], options[1].tolist()
        out = torch.full(vectors.shape[:2], -1, dtype=torch.long, device=tokens.device)
        counts = per_sample.tolist()
        starts = [sum(counts[:i]) for i in range(len(counts))]
        for k in sorted({c for c in counts if 2 <= c <= self.max_videos and bool(self.names_fitted[c])}):
            rows = [i for i, c in enumerate(counts) if c == k and listed[i] == k]
            if not rows:
                continue
            index = torch.tensor([starts[i] + j for i in rows for j in range(k)], device=tokens.device)
            chosen = self._match(tokens[index].reshape(len(rows), k, -1), vectors[rows][:, :k])
            pairs = torch.tensor(self._permutations[k], device=tokens.device)[chosen]  # option of each place
            out[rows, :k] = pairs.argsort(-1)  # place of each option
        return out

    def assignment_verdict(self, pairs: torch.Tensor) -> torch.Tensor:
        """S×H: per prompt the sum of the (video place, option) vectors of its assignment (``pairs``, S×k: the
        option of each place): each video's option can be read from the sum without decoding one code per
        assignment."""
        return self.assignments[torch.arange(pairs.shape[1], device=pairs.device), pairs].sum(1)


@dataclass
class ComparatorFit:
    """One comparator to fit (:meth:`CrossVideoFusion.fit`'s arguments): per prompt its k×N×H videos, the S×Dq
    question vectors, the S×3 targets (pick, attribute index, more) and the seed of its batch draws."""

    fusion: CrossVideoFusion
    videos: list[torch.Tensor]
    questions: torch.Tensor
    targets: torch.Tensor
    seed: int = 0


@dataclass
class _Prepared:
    feats: torch.Tensor  # S×K×W standardised, zero past a prompt's videos
    present: torch.Tensor  # S×K
    attribute: torch.Tensor  # S: the direction each question asks for
    sign: torch.Tensor  # S: +1 more, −1 less
    gold: torch.Tensor  # S: the pick
    flat: torch.Tensor
    generator: torch.Generator


def fit_comparators(jobs: list[ComparatorFit], steps: int | None = None, lr: float = 1e-2,
                    weight_decay: float = 0.1, batch_size: int = 16) -> list[dict[str, float]]:
    """Fit several comparators at once, each exactly as :meth:`CrossVideoFusion.fit` alone would (up to float
    rounding): its own statistics, ridge heads and seeded batch draws; AdamW acts per element, so one optimizer over
    the stacked directions moves each comparator's as its own would. Cross-fitting fits ~20 copies of one head;
    one loop over all of them costs about what one copy's loop did (Python and autograd overhead per step, not
    arithmetic, is the cost of these small problems). ``steps``: AdamW steps (default :data:`FIT_STEPS`). Returns
    each comparator's fit statistics."""
    if not jobs:
        return []
    steps = FIT_STEPS if steps is None else steps
    prepared = [job.fusion._prepare_fit(job) for job in jobs]
    widths, shapes = {p.feats.shape[2] for p in prepared}, {tuple(j.fusion.directions.shape) for j in jobs}
    if len(widths) != 1 or len(shapes) != 1:
        raise ValueError(f"comparators fitted together need one feature width and one direction shape, got "
                         f"widths {sorted(widths)} and directions {sorted(shapes)}")
    k = max(p.feats.shape[1] for p in prepared)
    feats = torch.cat([F.pad(p.feats, (0, 0, 0, k - p.feats.shape[1])) for p in prepared])
    present = torch.cat([F.pad(p.present, (0, k - p.present.shape[1])) for p in prepared])
    attribute = torch.cat([p.attribute for p in prepared])
    sign = torch.cat([p.sign for p in prepared]).to(feats.dtype)
    gold = torch.cat([p.gold for p in prepared])
    sizes = [len(p.gold) for p in prepared]
    offsets = list(itertools.accumulate(sizes[:-1], initial=0))
    copy_of = torch.arange(len(jobs)).repeat_interleave(batch_size)
    directions = nn.Parameter(torch.stack([j.fusion.directions.detach() for j in jobs]))  # C×A×W
    optimizer = torch.optim.AdamW([directions], lr=lr, weight_decay=weight_decay)
    with torch.enable_grad():
        for _ in range(steps):
            rows = torch.cat([torch.randint(0, n, (batch_size,), generator=p.generator) + offset
                              for p, n, offset in zip(prepared, sizes, offsets, strict=True)])
            # each row's copy's direction of the attribute asked, signed: what _scores reads from self.directions
            scores = _along(feats[rows], sign[rows, None] * directions[copy_of, attribute[rows]])
            scores = scores.masked_fill(~present[rows], float("-inf"))
            loss = F.cross_entropy(scores.float(), gold[rows], reduction="sum") / batch_size
            optimizer.zero_grad()
            loss.backward()
            optimizer.step()
    out = []
    for job, prep, fitted in zip(jobs, prepared, directions.detach(), strict=True):
        with torch.no_grad():
            job.fusion.directions.copy_(fitted)
        job.fusion.directions.requires_grad_(False)
        out.append(job.fusion._finish_fit(job, prep))
    return out


def _along(videos: torch.Tensor, direction: torch.Tensor) -> torch.Tensor:
    """videos S×k×W along one direction per prompt (S×W): S×k scores, scaled by √W."""
    return (videos @ direction.unsqueeze(-1)).squeeze(-1) / videos.shape[-1] ** 0.5


def _ridge(head: nn.Sequential, questions: torch.Tensor, targets: torch.Tensor, penalty: float = 10.0) -> None:
    """Set ``head`` (LayerNorm → Linear) to the ridge regression of ``targets`` on its normalised, per-dimension
    standardised inputs: closed form, and it names unseen questions' attribute where a gradient-fitted map of the
    same vectors over-fits the templates it saw (150 of 150 in comparator_probe.md)."""
    norm, linear = head[0], head[1]
    weight, bias = ridge_solve(norm(questions.to(linear.weight.dtype)), targets, penalty)
    linear.weight.copy_(weight.to(linear.weight.dtype))
    linear.bias.copy_(bias.to(linear.bias.dtype))


class ComparatorHead:
    """The comparator of a :class:`CrossVideoFusion` behind the read-out head interface. ``rows.targets``: per
    prompt (pick, attribute index, more) or None; the reading: a score per video (its softmax is the verdict)."""

    name = "comparator"
    reading = "pick"

    def __init__(self, fusion: CrossVideoFusion) -> None:
        self.fusion = fusion

    def _job(self, rows: HeadRows, seed: int) -> ComparatorFit:
        picked = [i for i, t in enumerate(rows.targets or []) if t is not None and t[0] >= 0
                  and len(rows.videos[i]) >= 2]
        if not picked or rows.questions is None:
            raise ValueError("the comparator needs at least one comparison to fit")
        chosen = rows.subset(picked)
        return ComparatorFit(self.fusion, chosen.videos, chosen.questions,
                             torch.tensor([list(t) for t in chosen.targets]), seed)

    def fit_rows(self, rows: HeadRows, seed: int = 0) -> dict[str, Any]:
        return fit_comparators([self._job(rows, seed)])[0]

    @staticmethod
    def fit_rows_together(fits: Sequence[tuple[ComparatorHead, HeadRows, int]]) -> list[dict[str, Any] | ValueError]:
        """``fit_rows`` of several heads (cross-fitting's copies: head, rows, seed) in one loop
        (:func:`fit_comparators`); a head with nothing to fit gets its ValueError instead of statistics."""
        jobs: list[ComparatorFit] = []
        refused: list[ValueError | None] = []
        for head, rows, seed in fits:
            try:
                jobs.append(head._job(rows, seed))
                refused.append(None)
            except ValueError as exc:
                refused.append(exc)
        fitted = iter(fit_comparators(jobs))
        return [next(fitted) if exc is None else exc for exc in refused]

    def silent(self, rows: HeadRows, i: int) -> torch.Tensor:
        return torch.zeros(len(rows.videos[i]))  # equal scores: the verdict is the mean of the place vectors

    def read_rows(self, rows: HeadRows) -> list[torch.Tensor]:
        if rows.questions is None:
            raise ValueError("the comparator reads the question vectors: rows.questions is None")
        fusion, out = self.fusion, []
        with torch.no_grad():
            for v, q in zip(rows.videos, rows.questions, strict=True):
                if len(v) < 2:
                    out.append(v.new_zeros(len(v)))
                    continue
                dtype = fusion.directions.dtype
                videos = fusion._normalised(v.flatten(1).to(dtype))[None]
                out.append(fusion._compare(videos, q[None].to(dtype))[0][0])
        return out


class NameMatcherHead:
    """The name matcher of a :class:`CrossVideoFusion` behind the read-out head interface. ``rows.targets``: per
    prompt the gold option of each video (a tuple) or None; the reading: the place of each listed option's video
    (−1 where the prompt is not matched)."""

    name = "name_matcher"
    reading = "places"

    def __init__(self, fusion: CrossVideoFusion) -> None:
        self.fusion = fusion

    def _matchable(self, rows: HeadRows, i: int) -> bool:
        k = len(rows.videos[i])
        return rows.options is not None and 2 <= k <= self.fusion.max_videos and len(rows.options[i]) == k

    def fit_rows(self, rows: HeadRows, seed: int = 0) -> dict[str, Any]:
        named = [i for i, t in enumerate(rows.targets or []) if t and len(t) == len(rows.videos[i])
                 and self._matchable(rows, i)]
        if not named:
            raise ValueError("the name matcher needs at least one prompt with named options to fit")
        chosen = rows.subset(named)
        return self.fusion.fit_names(chosen.videos, chosen.options, torch.tensor([list(t) for t in chosen.targets]),
                                     seed=seed)

    def silent(self, rows: HeadRows, i: int) -> torch.Tensor:
        return torch.full((len(rows.options[i]) if rows.options is not None else 0,), -1, dtype=torch.long)

    def read_rows(self, rows: HeadRows) -> list[torch.Tensor]:
        fusion, out = self.fusion, []
        with torch.no_grad():
            for i, v in enumerate(rows.videos):
                k = len(v)
                places = torch.full((len(rows.options[i]) if rows.options is not None else 0,), -1, dtype=torch.long)
                if self._matchable(rows, i) and bool(fusion.names_fitted[k]):
                    chosen = fusion._match(v.flatten(1)[None], rows.options[i][None])
                    pairs = torch.tensor(fusion._permutations[k])[chosen.cpu()][0]  # option of each place
                    places[:k] = pairs.argsort(-1)
                out.append(places)
        return out
