"""Training a LoRA adapter on the shipped Gemma-3 270M, on the CPU, with torch and peft.

transformers loads the shipped GGUF dequantized (about a minute); peft adds the adapter (rank
``rank`` on the attention and MLP projections). The loss is the cross-entropy of the reply's tokens
only, and the output layer (tied to the 262,144-token embeddings) is applied at those positions
only: exact, and half the time of logits at every position. AdamW with a linear warm-up and decay.

A run is resumable and deterministic: the examples' order per epoch comes from the seed, and a
checkpoint (the adapter, the optimizer, the step) is written every ``checkpoint_every`` steps, at a
time limit and on Ctrl-C; the same command goes on from it. The same examples, settings and seed on
the same machine give the same adapter, byte for byte.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import random
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from hbtp.deadline import Deadline, expired
from hbtp.errors import HbtpError, InputError
from hbtp.train.examples import Example

log = logging.getLogger(__name__)

#: The projections the adapter is put on (transformers' names).
TARGETS = ("q_proj", "k_proj", "v_proj", "o_proj", "gate_proj", "up_proj", "down_proj")
_INSTALL = "training needs the train extra: pip install -e '.[train]'"


class TrainingStopped(HbtpError):
    """Training stopped before its end (a time limit, Ctrl-C); a checkpoint lets it go on."""


@dataclass(frozen=True)
class TrainSettings:
    """How to train: the adapter's rank and alpha, the optimizer, the batches, the bounds."""

    rank: int = 8
    alpha: float = 16.0
    learning_rate: float = 1e-3
    epochs: int = 2
    batch: int = 8
    seed: int = 0
    threads: int = 2
    warmup_steps: int = 10
    checkpoint_every: int = 25

    def __post_init__(self) -> None:
        if self.rank < 1 or self.epochs < 1 or self.batch < 1 or self.threads < 1:
            raise InputError("rank, epochs, batch and threads must be at least 1")
        if not (math.isfinite(self.learning_rate) and self.learning_rate > 0):
            raise InputError(f"the learning rate must be a positive number, not {self.learning_rate}")

    def key(self, examples: Sequence[Example]) -> str:
        """What a checkpoint must match to be resumed: these settings and these examples."""
        digest = hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode())
        for example in examples:
            digest.update(f"{example.prompt}\0{example.reply}\0".encode())
        return digest.hexdigest()


@dataclass(frozen=True)
class TrainReport:
    """What a run did: steps, examples seen, the loss at the start and at the end, and the seconds of
    training steps (summed over the runs that went on from one checkpoint: the adapter's whole cost)."""

    steps: int
    examples: int
    first_loss: float
    last_loss: float
    seconds: float
    resumed_at: int


def load_model(base_model: Path, threads: int) -> tuple[Any, Any]:
    """The tokenizer and the model from the GGUF file (dequantized to float32)."""
    try:
        import torch
        from transformers import AutoModelForCausalLM, AutoTokenizer
    except ImportError as error:
        raise InputError(f"{_INSTALL} ({error})") from None
    torch.set_num_threads(threads)
    folder, name = str(base_model.parent), base_model.name
    tokenizer = AutoTokenizer.from_pretrained(folder, gguf_file=name)
    model = AutoModelForCausalLM.from_pretrained(folder, gguf_file=name, dtype=torch.float32)
    return tokenizer, model


def encode(tokenizer: Any, examples: Sequence[Example]) -> list[tuple[list[int], int]]:
    """Each example's token ids (the prompt with its BOS, then the reply) and the prompt's length."""
    encoded = []
    for example in examples:
        prompt = tokenizer(example.prompt).input_ids
        reply = tokenizer(example.reply, add_special_tokens=False).input_ids
        encoded.append((prompt + reply, len(prompt)))
    return encoded


def _batch(rows: Sequence[tuple[list[int], int]], pad: int) -> tuple[Any, Any, Any]:
    import torch

    width = max(len(ids) for ids, _ in rows)
    ids = torch.full((len(rows), width), pad, dtype=torch.long)
    attention = torch.zeros((len(rows), width), dtype=torch.long)
    reply = torch.zeros((len(rows), width), dtype=torch.bool)
    for row, (tokens, prompt) in enumerate(rows):
        ids[row, : len(tokens)] = torch.tensor(tokens)
        attention[row, : len(tokens)] = 1
        reply[row, prompt : len(tokens)] = True
    return ids, attention, reply


def reply_loss(model: Any, ids: Any, attention: Any, reply: Any) -> Any:
    """The cross-entropy of the reply tokens, the output layer applied at their positions only."""
    import torch

    causal = model.get_base_model()
    hidden = causal.model(input_ids=ids, attention_mask=attention).last_hidden_state
    chosen = reply[:, 1:]  # the position before a token predicts it
    logits = hidden[:, :-1][chosen] @ causal.lm_head.weight.T
    cap = getattr(causal.config, "final_logit_softcapping", None)
    if cap:
        logits = torch.tanh(logits / cap) * cap
    return torch.nn.functional.cross_entropy(logits.float(), ids[:, 1:][chosen])


def _batches(count: int, settings: TrainSettings) -> list[list[int]]:
    """The examples of every step, epoch after epoch, each epoch in an order drawn from the seed."""
    steps: list[list[int]] = []
    for epoch in range(settings.epochs):
        order = list(range(count))
        random.Random(settings.seed * 7919 + epoch).shuffle(order)
        steps += [order[i : i + settings.batch] for i in range(0, count, settings.batch)]
    return steps


def _rate(step: int, total: int, settings: TrainSettings) -> float:
    if step < settings.warmup_steps:
        return (step + 1) / settings.warmup_steps
    return max(0.0, (total - step) / max(1, total - settings.warmup_steps))


@dataclass
class _Run:
    """The state of one training run, saved in and restored from its checkpoint."""

    model: Any
    optimizer: Any
    schedule: Any
    step: int
    losses: list[float]
    #: Seconds spent in training steps, over every run that went on from this checkpoint.
    seconds: float = 0.0

    def save(self, path: Path, key: str) -> None:
        import torch

        state = {
            "key": key,
            "step": self.step,
            "losses": self.losses,
            "seconds": self.seconds,
            "adapter": _adapter_state(self.model),
            "optimizer": self.optimizer.state_dict(),
            "schedule": self.schedule.state_dict(),
        }
        staged = path.with_name(path.name + ".partial")
        torch.save(state, staged)
        os.replace(staged, path)


def with_lora(model: Any, settings: TrainSettings) -> Any:
    """``model`` with a fresh LoRA of ``settings``' rank on :data:`TARGETS` (peft's model)."""
    from peft import LoraConfig, get_peft_model

    config = LoraConfig(
        r=settings.rank, lora_alpha=settings.alpha, lora_dropout=0.0, bias="none", target_modules=list(TARGETS)
    )
    with warnings.catch_warnings():
        # peft asks transformers 5 a question under its deprecated name: a warning for us, not the user
        warnings.filterwarnings("ignore", message=".*is_gradient_checkpointing.*", category=FutureWarning)
        return get_peft_model(model, config)


def _new_run(model: Any, settings: TrainSettings, total: int) -> _Run:
    import torch

    torch.manual_seed(settings.seed)
    adapted = with_lora(model, settings)
    adapted.train()
    trainable = [p for p in adapted.parameters() if p.requires_grad]
    optimizer = torch.optim.AdamW(trainable, lr=settings.learning_rate, weight_decay=0.0)
    schedule = torch.optim.lr_scheduler.LambdaLR(optimizer, lambda step: _rate(step, total, settings))
    return _Run(adapted, optimizer, schedule, 0, [])


def _resume(run: _Run, checkpoint: Path, key: str) -> None:
    """Go on from ``checkpoint`` when it belongs to this run (same settings and examples)."""
    import torch
    from peft import set_peft_model_state_dict

    if not checkpoint.is_file():
        return
    state = torch.load(checkpoint, weights_only=False)
    if state.get("key") != key:
        log.warning("%s belongs to another run (other examples or settings): starting afresh", checkpoint)
        return
    set_peft_model_state_dict(run.model, state["adapter"])
    run.optimizer.load_state_dict(state["optimizer"])
    run.schedule.load_state_dict(state["schedule"])
    run.step, run.losses = int(state["step"]), list(state["losses"])
    run.seconds = float(state.get("seconds", 0.0))
    log.info("resuming from step %d (%s)", run.step, checkpoint)


def train(
    examples: Sequence[Example],
    settings: TrainSettings,
    base_model: Path,
    work: Path,
    *,
    deadline: Deadline | None = None,
    progress: Callable[[Iterator[int], int, int], Iterator[int]] | None = None,
) -> tuple[dict[str, Any], TrainReport]:
    """Train an adapter on ``examples``; its state (numpy arrays, peft's names) and a report.

    ``work`` holds the checkpoint; ``deadline`` stops the run with
    a checkpoint (:class:`TrainingStopped`), as does Ctrl-C; ``progress(steps, start, total)``
    wraps the step counter (a progress bar)."""
    tokenizer, model = load_model(base_model, settings.threads)
    rows = encode(tokenizer, examples)
    plan = _batches(len(rows), settings)
    run = _new_run(model, settings, len(plan))
    key = settings.key(examples)
    checkpoint = work / "checkpoint.pt"
    _resume(run, checkpoint, key)
    resumed_at = run.step
    pad = tokenizer.pad_token_id if tokenizer.pad_token_id is not None else 0
    steps: Iterator[int] = iter(range(run.step, len(plan)))
    for step in progress(steps, run.step, len(plan)) if progress is not None else steps:
        began = time.monotonic()
        try:
            _step(run, [rows[i] for i in plan[step]], pad)
            run.seconds += time.monotonic() - began
        except KeyboardInterrupt:
            run.save(checkpoint, key)
            raise
        if run.step % settings.checkpoint_every == 0 or expired(deadline):
            run.save(checkpoint, key)
        if expired(deadline) and run.step < len(plan):
            raise TrainingStopped(
                f"time limit reached after step {run.step} of {len(plan)}; the same command goes on from there"
            )
    run.save(checkpoint, key)
    state = {name: value.detach().cpu().numpy() for name, value in _adapter_state(run.model).items()}
    losses = run.losses or [math.nan]
    report = TrainReport(len(plan), len(rows), losses[0], losses[-1], run.seconds, resumed_at)
    return state, report


def _step(run: _Run, rows: Sequence[tuple[list[int], int]], pad: int) -> None:
    ids, attention, reply = _batch(rows, pad)
    loss = reply_loss(run.model, ids, attention, reply)
    loss.backward()
    run.optimizer.step()
    run.schedule.step()
    run.optimizer.zero_grad(set_to_none=True)
    run.losses.append(round(float(loss.detach()), 6))
    run.step += 1


def _adapter_state(model: Any) -> dict[str, Any]:
    from peft import get_peft_model_state_dict

    # No embedding layer is adapted: saying so spares peft looking for the base model's config
    # (on the Hugging Face hub when not on disk) and its warning when there is none.
    state: dict[str, Any] = get_peft_model_state_dict(model, save_embedding_layers=False)
    return state


__all__ = [
    "TARGETS",
    "TrainReport",
    "TrainSettings",
    "TrainingStopped",
    "encode",
    "load_model",
    "reply_loss",
    "train",
    "with_lora",
]
