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
    """Write every file or none: each goes to a temporary name in its folder, then all are renamed."""
    staged: list[tuple[Path, Path]] = []
    mode = new_file_mode()
    try:
        for path, data in files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            descriptor, name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
            staged.append((Path(name), path))
            with os.fdopen(descriptor, "wb") as handle:
                handle.write(data.encode("utf-8") if isinstance(data, str) else data)
            os.chmod(name, mode)  # mkstemp creates 0600
    except OSError as error:
        for temporary, _ in staged:
            temporary.unlink(missing_ok=True)
        raise InputError(f"cannot write {error.filename or 'file'}: {error.strerror}") from None
    for temporary, path in staged:
        os.replace(temporary, path)


def write_atomically(path: Path, data: str | bytes) -> None:
    """Write one file through a temporary file in the same folder, then rename it."""
    write_all_atomically({path: data})
