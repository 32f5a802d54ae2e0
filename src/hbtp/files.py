"""Writing files so that nothing is ever left half-written."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path

from hbtp.errors import InputError


def new_file_mode() -> int:
    """The mode a new file gets under the current umask (``0o644`` under the common ``022``)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def write_all_atomically(files: Mapping[Path, str | bytes]) -> None:
    """Write every file or none: each goes to a temporary name in its folder, then all are renamed.

    An error names the file the caller asked for (never the temporary one) and removes every
    temporary file; the targets are then left as they were (a failure while renaming, after the
    data is safely written, is the only case where some targets may already be replaced).
    """
    staged: list[tuple[Path, Path]] = []
    mode = new_file_mode()
    target: Path | None = None

    def clean_up() -> None:
        for temporary, _ in staged:
            temporary.unlink(missing_ok=True)

    try:
        for target, data in files.items():
            target.parent.mkdir(parents=True, exist_ok=True)
            descriptor, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
            staged.append((Path(name), target))
            with os.fdopen(descriptor, "wb") as handle:
                handle.write(data.encode("utf-8") if isinstance(data, str) else data)
            os.chmod(name, mode)  # mkstemp creates 0600
        for temporary, target in staged:
            os.replace(temporary, target)
    except OSError as error:
        clean_up()
        raise InputError(f"cannot write {target if target is not None else 'file'}: {error.strerror}") from None


def write_atomically(path: Path, data: str | bytes) -> None:
    """Write one file through a temporary file in the same folder, then rename it."""
    write_all_atomically({path: data})
