"""The files a user names: read only regular files, never more than a stated cap, and write only
regular files, all or nothing.

Every file hbtp reads or writes on a user's behalf goes through this module, so that the rules
hold everywhere:

* **Reads** (:func:`read_bytes`, :func:`read_text`) refuse anything that is not a regular file
  (a device such as ``/dev/zero``, a FIFO, a folder) before opening it, and refuse a file larger
  than the cap of its kind (:class:`InputKind`), naming the cap. ``-`` reads standard input, under
  the same cap. A symbolic link is followed: what it points to must be a regular file.
* **Writes** (:func:`write_all_atomically`, :func:`open_output`) write only regular files. An
  existing target that is not a regular file (a device such as ``/dev/full``, a FIFO, a folder) or
  that is a symbolic link is refused in one line, never replaced or followed. A missing folder is
  an error unless the command documents that it creates its output folder (``create_folders``).
"""

from __future__ import annotations

import enum
import io
import os
import stat
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import IO

from hbtp.errors import InputError, SourceError

MIB = 1024 * 1024


class InputKind(enum.Enum):
    """What a file holds, with the largest size hbtp reads of it (``cap``, in bytes)."""

    PDDL = ("PDDL file", 64 * MIB)
    TREE = ("tree file", 256 * MIB)
    TRACE = ("trace", 256 * MIB)
    DATASET = ("dataset file", 64 * MIB)
    HINTS = ("hints file", 64 * MIB)
    RECORD = ("record file", 64 * MIB)
    RESULTS = ("results file", 256 * MIB)
    SETTINGS = ("settings file", 4 * MIB)
    GOAL = ("goal", 1 * MIB)
    INSTRUCTION = ("instruction", 1 * MIB)

    def __init__(self, label: str, cap: int) -> None:
        self.label = label
        self.cap = cap


def size_text(size: int) -> str:
    """``64 MiB``, ``512 KiB`` or ``100 bytes``: a cap as its error message names it."""
    if size >= MIB and size % MIB == 0:
        return f"{size // MIB} MiB"
    if size >= 1024 and size % 1024 == 0:
        return f"{size // 1024} KiB"
    return f"{size} bytes"


def _kind_of(mode: int) -> str:
    """What a file that is not a regular one is, in words."""
    for test, name in (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISLNK, "a symbolic link"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def _too_large(label: str, kind: InputKind) -> SourceError:
    return SourceError(f"the {kind.label} is larger than the limit of {size_text(kind.cap)}", label)


def _unreadable(label: str, kind: InputKind, reason: str) -> SourceError:
    return SourceError(f"cannot read the {kind.label}: {reason}", label)


def read_bytes(name: str | os.PathLike[str], kind: InputKind) -> bytes:
    """The bytes of the regular file ``name`` (``-``: standard input), at most ``kind.cap`` of them.

    Raises :class:`~hbtp.errors.SourceError` (naming the file) for a file that cannot be read, is
    not a regular file, or is larger than the cap.
    """
    label = str(name)
    if label == "-":
        return _read_stdin(kind)
    try:
        mode = os.stat(name).st_mode  # looked at before opening: opening a device can act
        if not stat.S_ISREG(mode):
            raise _unreadable(label, kind, f"it is {_kind_of(mode)}")
        descriptor = os.open(name, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as error:
        raise _unreadable(label, kind, error.strerror or str(error)) from None
    with os.fdopen(descriptor, "rb") as handle:
        status = os.fstat(descriptor)
        if not stat.S_ISREG(status.st_mode):  # replaced between the two looks
            raise _unreadable(label, kind, f"it is {_kind_of(status.st_mode)}")
        if status.st_size > kind.cap:
            raise _too_large(label, kind)
        try:
            data = handle.read(kind.cap + 1)  # a file that grows, or claims size 0 (/proc), stays bounded
        except OSError as error:
            raise _unreadable(label, kind, error.strerror or str(error)) from None
    if len(data) > kind.cap:
        raise _too_large(label, kind)
    return data


def _read_stdin(kind: InputKind) -> bytes:
    stream = sys.stdin
    if stream is None:
        raise _unreadable("standard input", kind, "no standard input")
    buffer = getattr(stream, "buffer", None)
    try:
        if buffer is not None:
            data: bytes = buffer.read(kind.cap + 1)
        else:
            data = stream.read(kind.cap + 1).encode("utf-8")
    except OSError as error:
        raise _unreadable("standard input", kind, error.strerror or str(error)) from None
    if len(data) > kind.cap:
        raise _too_large("standard input", kind)
    return data


def decode_text(data: bytes, label: str, kind: InputKind) -> str:
    """``data`` as UTF-8 text (a byte-order mark dropped); bad UTF-8 is a
    :class:`~hbtp.errors.SourceError` at its line and column, naming its byte offset."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        before = data[: error.start].decode("utf-8-sig", errors="replace")
        line = before.count("\n") + 1
        column = len(before) - (before.rfind("\n") + 1) + 1
        raise SourceError(f"the {kind.label} is not UTF-8 text (byte {error.start})", label, line, column) from None


def read_text(name: str | os.PathLike[str], kind: InputKind) -> str:
    """The UTF-8 text of the regular file ``name`` (``-``: standard input): :func:`read_bytes`,
    then :func:`decode_text`."""
    label = "standard input" if str(name) == "-" else str(name)
    return decode_text(read_bytes(name, kind), label, kind)


def new_file_mode() -> int:
    """The mode a new file gets under the current umask (``0o644`` under the common ``022``)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def check_output(path: Path, *, create_folders: bool = False) -> None:
    """Refuse an output target hbtp must not write: an existing one that is not a regular file or
    is a symbolic link, or one whose folder is missing (created instead with ``create_folders``)."""
    folder = path.parent
    if create_folders:
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise InputError(f"cannot write {path}: cannot create the folder {folder}: {error.strerror}") from None
    if not folder.is_dir():
        problem = "is not a folder" if folder.exists() else "does not exist"
        raise InputError(f"cannot write {path}: the folder {folder} {problem}")
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as error:
        raise InputError(f"cannot write {path}: {error.strerror}") from None
    if stat.S_ISLNK(mode):
        raise InputError(f"cannot write {path}: it is a symbolic link; give the file it points to")
    if not stat.S_ISREG(mode):
        raise InputError(f"cannot write {path}: it is {_kind_of(mode)}; hbtp writes only regular files")


def write_all_atomically(files: Mapping[Path, str | bytes], *, create_folders: bool = False) -> None:
    """Write every file or none: each goes to a temporary name in its folder, then all are renamed.

    Every target is checked first (:func:`check_output`), and again just before its rename. An
    error names the file the caller asked for (never the temporary one) and removes every temporary
    file; the targets are then left as they were (a failure while renaming, after the data is
    safely written, is the only case where some targets may already be replaced).
    """
    for path in files:
        check_output(Path(path), create_folders=create_folders)
    staged: list[tuple[Path, Path]] = []
    mode = new_file_mode()
    target: Path | None = None

    def clean_up() -> None:
        for temporary, _ in staged:
            temporary.unlink(missing_ok=True)

    try:
        for target, data in files.items():
            descriptor, name = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
            staged.append((Path(name), target))
            with os.fdopen(descriptor, "wb") as handle:
                handle.write(data.encode("utf-8") if isinstance(data, str) else data)
            os.chmod(name, mode)  # mkstemp creates 0600
        for temporary, target in staged:
            check_output(target)
            os.replace(temporary, target)
    except InputError:
        clean_up()
        raise
    except OSError as error:
        clean_up()
        raise InputError(f"cannot write {target if target is not None else 'file'}: {error.strerror}") from None


def write_atomically(path: Path, data: str | bytes, *, create_folders: bool = False) -> None:
    """Write one file through a temporary file in the same folder, then rename it."""
    write_all_atomically({path: data}, create_folders=create_folders)


def open_output(path: Path, *, append: bool = False, create_folders: bool = False) -> IO[str]:
    """``path`` opened for UTF-8 text written as it comes (rows of a long run): a regular file only,
    never through a symbolic link; emptied first unless ``append``."""
    check_output(path, create_folders=create_folders)
    flags = os.O_WRONLY | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    flags |= os.O_APPEND if append else 0
    try:
        descriptor = os.open(path, flags, 0o666)
    except OSError as error:
        raise InputError(f"cannot write {path}: {error.strerror}") from None
    mode = os.fstat(descriptor).st_mode
    if not stat.S_ISREG(mode):
        os.close(descriptor)
        raise InputError(f"cannot write {path}: it is {_kind_of(mode)}; hbtp writes only regular files")
    if not append:
        os.ftruncate(descriptor, 0)
    return io.TextIOWrapper(os.fdopen(descriptor, "wb"), encoding="utf-8", newline="")


__all__ = [
    "MIB",
    "InputKind",
    "check_output",
    "decode_text",
    "new_file_mode",
    "open_output",
    "read_bytes",
    "read_text",
    "size_text",
    "write_all_atomically",
    "write_atomically",
]
