"""A trained LoRA written as the GGUF adapter llama.cpp applies to the shipped base model.

llama.cpp's adapter format (as its ``convert_lora_to_gguf.py`` writes it): metadata
``general.architecture`` (the base model's), ``general.type = adapter``, ``adapter.type = lora``,
``adapter.lora.alpha``; a tensor pair per adapted weight, named like the base model's tensor with
``.lora_a`` and ``.lora_b``. peft's ``lora_A.weight`` (rank x in) and ``lora_B.weight`` (out x
rank) are written as they are: in ggml's order their shapes are [in, rank] and [rank, out], and
llama.cpp reads the rank from them. It applies ``scale * alpha / rank``, as peft does. The shapes
are checked against the base model here: llama.cpp's own refusal of a misfit says little.

hbtp adds what the adapter was made for (:mod:`hbtp.llm.backends.adapters`): the base model's
sha256, the world's key, the prompt format, and how it was trained.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hbtp.errors import InputError
from hbtp.files import check_output, write_atomically
from hbtp.llm.backends.adapters import KEY_FORMAT, PROMPT_FORMAT

#: The projections adapted, by their name in the transformers model and their tensor in the GGUF.
PROJECTIONS = {
    "self_attn.q_proj": "attn_q",
    "self_attn.k_proj": "attn_k",
    "self_attn.v_proj": "attn_v",
    "self_attn.o_proj": "attn_output",
    "mlp.gate_proj": "ffn_gate",
    "mlp.up_proj": "ffn_up",
    "mlp.down_proj": "ffn_down",
}
_KEY = re.compile(
    r"(?:^|\.)layers\.(\d+)\.(self_attn\.[qkvo]_proj|mlp\.(?:gate|up|down)_proj)\.lora_([AB])(?:\.default)?\.weight$"
)


def gguf_tensors(state: Mapping[str, Any]) -> dict[str, Any]:
    """peft's adapter state (numpy arrays) under llama.cpp's tensor names."""
    import numpy as np

    tensors: dict[str, Any] = {}
    for key, value in state.items():
        match = _KEY.search(key)
        if match is None:
            raise InputError(f"the adapter has a tensor hbtp cannot write: {key!r}")
        layer, projection, side = int(match.group(1)), match.group(2), match.group(3).lower()
        tensors[f"blk.{layer}.{PROJECTIONS[projection]}.weight.lora_{side}"] = np.ascontiguousarray(value)
    return tensors


def base_shapes(base_model: Path) -> tuple[str, dict[str, list[int]]]:
    """The base model's architecture and its tensors' shapes (ggml order)."""
    import gguf

    reader = gguf.GGUFReader(str(base_model))
    architecture = str(reader.fields["general.architecture"].contents())
    return architecture, {tensor.name: [int(n) for n in tensor.shape] for tensor in reader.tensors}


def check_shapes(tensors: Mapping[str, Any], shapes: Mapping[str, list[int]]) -> int:
    """The adapter's rank, after checking every pair fits its base tensor (:class:`InputError`)."""
    ranks: set[int] = set()
    for name in sorted({key.rsplit(".lora_", 1)[0] for key in tensors}):
        a, b = tensors.get(f"{name}.lora_a"), tensors.get(f"{name}.lora_b")
        if a is None or b is None or name not in shapes:
            raise InputError(f"the adapter's {name} has no pair or no base tensor")
        base, ne_a, ne_b = shapes[name], list(a.shape[::-1]), list(b.shape[::-1])
        if not (base[0] == ne_a[0] and base[1] == ne_b[1] and ne_a[1] == ne_b[0]):
            raise InputError(f"the adapter's {name} does not fit the base model ({ne_a}, {ne_b} on {base})")
        ranks.add(ne_a[1])
    if len(ranks) != 1:
        raise InputError(f"the adapter's tensors have several ranks: {sorted(ranks)}")
    return ranks.pop()


def write_adapter(
    state: Mapping[str, Any], alpha: float, base_model: Path, out: Path, facts: Mapping[str, str | int]
) -> int:
    """Write peft's adapter ``state`` to ``out`` (F16), checked against ``base_model``; ``facts``
    (metadata keys and values: the world, the base's sha256, how it was trained) go into its
    metadata. Returns its size."""
    import gguf
    import numpy as np

    check_output(out)
    architecture, shapes = base_shapes(base_model)
    tensors = gguf_tensors(state)
    check_shapes(tensors, shapes)
    staged = out.with_name(f".{out.name}.staged")
    writer = gguf.GGUFWriter(str(staged), arch=architecture)
    writer.add_type(gguf.GGUFType.ADAPTER)
    writer.add_name("hbtp-adapter")
    writer.add_string(gguf.Keys.Adapter.TYPE, "lora")
    writer.add_float32(gguf.Keys.Adapter.LORA_ALPHA, float(alpha))
    writer.add_uint32(KEY_FORMAT, PROMPT_FORMAT)
    for key, value in sorted(facts.items()):
        if isinstance(value, int):
            writer.add_uint64(key, value)
        else:
            writer.add_string(key, value)
    for name in sorted(tensors):
        writer.add_tensor(name, tensors[name].astype(np.float16))
    writer.write_header_to_file()
    writer.write_kv_data_to_file()
    writer.write_tensors_to_file()
    writer.close()
    try:
        write_atomically(out, staged.read_bytes())
    finally:
        staged.unlink(missing_ok=True)
    return out.stat().st_size


__all__ = ["PROJECTIONS", "base_shapes", "check_shapes", "gguf_tensors", "write_adapter"]
