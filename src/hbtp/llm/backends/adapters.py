"""LoRA adapters of the local model: which one a world uses, and whether a file fits.

An adapter teaches the shipped Gemma-3 270M one world (``hbtp train``, :mod:`hbtp.train`): a GGUF
LoRA file that llama.cpp applies to the unchanged base model. Which one ``--llm local`` uses
(:class:`AdapterChoice`): ``--adapter PATH``; ``--adapter none``; by default the world's own: the
shipped adapter of a shipped scenario (package data, ``hbtp/llm/adapters/``) or the shipped adapter
made for the world's PDDL files (a world grown from a shipped one by cloning its objects, as
``hbtp bench payoff`` grows RobotHow, is read from the same files: every object and fact the
adapter was taught is in it, the clones are names it was never taught), else the one
``hbtp train --pddl`` left in the cache for that world. A shipped adapter may come with a
companion that reads instructions (``<scenario>.instructions.gguf``, :func:`instruction_adapter`):
one model load serves both, each request switching to its adapter.

An adapter records what it was made for (GGUF metadata, read here without the ``gguf`` package):
the base model's sha256 and the world's key (a hash of its PDDL files). A file that is not a GGUF
adapter, or was made for another base model or another world, is left out with a one-line warning,
and the base model answers as it would without one.
"""

from __future__ import annotations

import enum
import hashlib
import logging
import struct
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, BinaryIO

from hbtp.errors import InputError
from hbtp.llm.spelling import Spelling

log = logging.getLogger(__name__)

#: Metadata keys hbtp writes into an adapter (beside llama.cpp's ``general.*`` and ``adapter.*``).
KEY_BASE = "hbtp.base_sha256"
KEY_WORLD = "hbtp.world"
KEY_FORMAT = "hbtp.prompt_format"
#: The action predicates of actions the adapter's plans leave out for the check to put back
#: (:mod:`hbtp.train.abridge`), comma-separated: a reply read as hints, unchecked, names them too.
KEY_FILLED = "hbtp.filled_predicates"
#: The prompt formats an adapter may be trained on (:func:`hbtp.llm.prompt.taught_prompt`), each with
#: the spelling of its plans' actions: 2 ``Walk_milk``, 3 ``Walk milk`` (:mod:`hbtp.llm.spelling`).
#: An adapter of another format would be asked questions it was never taught.
SPELLINGS: dict[int, Spelling] = {2: Spelling.UNDERSCORED, 3: Spelling.SPACED}
#: The format ``hbtp train`` teaches now.
PROMPT_FORMAT = 3
#: A shipped adapter ``<name>.gguf`` may have a companion ``<name>.instructions.gguf`` that reads
#: instructions (taught with more instruction examples); the first one answers the hints.
INSTRUCTIONS_SUFFIX = ".instructions.gguf"
#: The most metadata entries read from an adapter (a real one has about a dozen).
_MAX_FIELDS = 4096
_MAX_STRING = 1 << 20


class AdapterMode(enum.Enum):
    """``--adapter``: the world's own (auto), none, or a file."""

    AUTO = "auto"
    NONE = "none"
    FILE = "file"


@dataclass(frozen=True)
class AdapterChoice:
    """Which adapter the local model uses (see the module docstring)."""

    mode: AdapterMode = AdapterMode.AUTO
    path: Path | None = None

    @classmethod
    def parse(cls, text: str) -> AdapterChoice:
        """``auto``, ``none`` or a file name (a file so named: ``./none``)."""
        if text in ("auto", "none"):
            return cls(AdapterMode(text))
        if not text:
            raise InputError("--adapter needs auto, none or a file name")
        return cls(AdapterMode.FILE, Path(text))


def world_key(domain_file: str | Path, problem_file: str | Path) -> str:
    """The key of a world: a hash of its PDDL files' bytes (what an adapter was trained on)."""
    digest = hashlib.sha256()
    for path in (domain_file, problem_file):
        digest.update(Path(path).read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:32]


def _shipped_folder() -> Path:
    """Where the shipped adapters are (package data)."""
    return Path(str(resources.files("hbtp.llm") / "adapters"))


def shipped_adapter(scenario: str) -> Path | None:
    """The adapter shipped for a shipped scenario, if there is one."""
    entry = _shipped_folder() / f"{scenario}.gguf"
    return entry if entry.is_file() else None


def shipped_for_world(world: str) -> Path | None:
    """The shipped adapter made for the world ``world`` (its PDDL files' key), if there is one."""
    for path in sorted(_shipped_folder().iterdir()):
        if path.name.endswith(".gguf") and not path.name.endswith(INSTRUCTIONS_SUFFIX) and path.is_file():
            try:
                made_for = read_metadata(path).get(KEY_WORLD)
            except (OSError, ValueError, struct.error):
                continue
            if made_for == world:
                return path
    return None


def cache_folder() -> Path:
    """Where ``hbtp train --pddl`` leaves adapters (the model cache's ``adapters`` folder)."""
    from hbtp.llm.backends.local import model_cache_dir

    return model_cache_dir().parent / "adapters"


def cached_adapter(key: str) -> Path:
    """Where the adapter trained for the world ``key`` lives in the cache (it may not exist)."""
    return cache_folder() / f"{key}.gguf"


def read_metadata(path: Path) -> dict[str, Any]:
    """The metadata of a GGUF file (scalars and strings; arrays are skipped); :class:`ValueError`
    for a file that is not GGUF."""
    with path.open("rb") as handle:
        if handle.read(4) != b"GGUF":
            raise ValueError("not a GGUF file")
        version, _tensors, count = struct.unpack("<IQQ", _exactly(handle, 20))
        if version < 2:
            raise ValueError(f"GGUF version {version} is too old")
        if count > _MAX_FIELDS:
            raise ValueError(f"{count} metadata entries (at most {_MAX_FIELDS} are read)")
        fields: dict[str, Any] = {}
        for _ in range(count):
            key = _string(handle)
            (kind,) = struct.unpack("<I", _exactly(handle, 4))
            fields[key] = _value(handle, kind)
    return fields


_SCALARS = {0: "<B", 1: "<b", 2: "<H", 3: "<h", 4: "<I", 5: "<i", 6: "<f", 7: "<?", 10: "<Q", 11: "<q", 12: "<d"}


def _value(handle: BinaryIO, kind: int) -> Any:
    if kind in _SCALARS:
        form = _SCALARS[kind]
        return struct.unpack(form, _exactly(handle, struct.calcsize(form)))[0]
    if kind == 8:
        return _string(handle)
    if kind == 9:
        item, count = struct.unpack("<IQ", _exactly(handle, 12))
        if count > _MAX_STRING:
            raise ValueError("an array too long for an adapter's metadata")
        for _ in range(count):
            _value(handle, item)
        return None
    raise ValueError(f"unknown GGUF value type {kind}")


def _string(handle: BinaryIO) -> str:
    (length,) = struct.unpack("<Q", _exactly(handle, 8))
    if length > _MAX_STRING:
        raise ValueError("a metadata string too long")
    return _exactly(handle, length).decode("utf-8", errors="replace")


def _exactly(handle: BinaryIO, size: int) -> bytes:
    data = handle.read(size)
    if len(data) != size:
        raise ValueError("the file ends too early")
    return data


def unfit(path: Path, *, world: str | None, base_sha256: str | None) -> str | None:
    """Why the adapter ``path`` does not fit (``None`` when it does): not a GGUF LoRA adapter, made
    for another base model, another world, or another prompt format."""
    try:
        fields = read_metadata(path)
    except (OSError, ValueError, struct.error) as error:
        return f"it cannot be read as a GGUF adapter ({error})"
    if fields.get("general.type") != "adapter" or fields.get("adapter.type") != "lora":
        return "it is not a LoRA adapter"
    made_for = fields.get(KEY_BASE)
    if base_sha256 and made_for and made_for != base_sha256:
        return "it was made for another base model"
    if world and fields.get(KEY_WORLD) not in (None, world):
        return "it was made for another world (other PDDL files)"
    if fields.get(KEY_FORMAT, PROMPT_FORMAT) not in SPELLINGS:
        known = " or ".join(map(str, SPELLINGS))
        return f"it was trained on prompt format {fields.get(KEY_FORMAT)}, not {known}"
    return None


def spelling_of(path: Path) -> Spelling:
    """How the adapter ``path`` (one :func:`unfit` accepts) spells the actions of its plans."""
    try:
        written = read_metadata(path).get(KEY_FORMAT, PROMPT_FORMAT)
    except (OSError, ValueError, struct.error):
        written = PROMPT_FORMAT
    return SPELLINGS.get(written, SPELLINGS[PROMPT_FORMAT])


def filled_of(path: Path) -> tuple[str, ...]:
    """The action predicates the adapter ``path`` leaves to the check of its plans (:data:`KEY_FILLED`)."""
    try:
        written = read_metadata(path).get(KEY_FILLED, "")
    except (OSError, ValueError, struct.error):
        return ()
    return tuple(name for name in str(written).split(",") if name)


def _candidate(choice: AdapterChoice, scenario: str, world: str | None) -> Path | None:
    """The file ``choice`` names, or the world's own; ``None`` when there is none."""
    if choice.mode is AdapterMode.NONE:
        return None
    if choice.mode is AdapterMode.FILE:
        path = choice.path
        if path is None or not path.is_file():
            log.warning("adapter %s: no such file; the base model answers", path)
            return None
        return path
    shipped = shipped_adapter(scenario)
    if shipped is not None or world is None:
        return shipped
    shipped = shipped_for_world(world)
    if shipped is not None:
        return shipped
    cached = cached_adapter(world)
    return cached if cached.is_file() else None


def instruction_adapter(
    choice: AdapterChoice, adapter: Path | None, *, world: str | None, base_sha256: str | None
) -> Path | None:
    """The companion that reads instructions of the shipped ``adapter`` that ``--adapter auto``
    chose (``None``: ``adapter`` reads them too), checked as :func:`choose_adapter` checks."""
    if choice.mode is not AdapterMode.AUTO or adapter is None or not adapter.name.endswith(".gguf"):
        return None
    companion = adapter.with_name(adapter.name.removesuffix(".gguf") + INSTRUCTIONS_SUFFIX)
    if adapter.parent != _shipped_folder() or not companion.is_file():
        return None
    reason = unfit(companion, world=world, base_sha256=base_sha256)
    if reason is not None:
        log.warning("adapter %s is not used: %s; %s reads the instructions", companion, reason, adapter.name)
        return None
    return companion


def choose_adapter(choice: AdapterChoice, *, scenario: str, world: str | None, base_sha256: str | None) -> Path | None:
    """The adapter file the local model uses for ``scenario`` (the world ``world``), checked, or
    ``None`` (the base model) when there is none or it does not fit (a one-line warning)."""
    candidate = _candidate(choice, scenario, world)
    if candidate is None:
        return None
    reason = unfit(candidate, world=world, base_sha256=base_sha256)
    if reason is not None:
        log.warning("adapter %s is not used: %s; the base model answers", candidate, reason)
        return None
    return candidate


__all__ = [
    "INSTRUCTIONS_SUFFIX",
    "KEY_BASE",
    "KEY_FILLED",
    "KEY_FORMAT",
    "KEY_WORLD",
    "PROMPT_FORMAT",
    "SPELLINGS",
    "AdapterChoice",
    "AdapterMode",
    "cached_adapter",
    "choose_adapter",
    "filled_of",
    "instruction_adapter",
    "read_metadata",
    "shipped_adapter",
    "shipped_for_world",
    "spelling_of",
    "unfit",
    "world_key",
]
