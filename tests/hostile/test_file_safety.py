"""Files hbtp must never touch, and reads that must stay bounded (issue: hostile input, part A).

Every output (``plan -o/--export/--record``, ``run --trace/--btlog``, ``view -o``, ``export -o``,
``dataset convert``, ``dataset generate -o``, ``examples generate -o``, ``validate-optimal -o`` and the
files a benchmark writes into its ``-o DIR``) writes only regular files: an existing FIFO, device,
folder or symbolic link is refused in one line and left as it was, and a missing folder is an error.
Every input is a regular file (or ``-``) no larger than its kind's cap. A tree file cannot make
hbtp open a path outside its own folder. No test here opens a real device: the device case uses a
null device node made in the test's own folder (skipped where that is not allowed).
"""

from __future__ import annotations

import io
import json
import os
import resource
import stat
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from hbtp.bench.results import ResultsFile, Row, write_json
from hbtp.cli import EXIT_INPUT, EXIT_NOT_SOLVED, EXIT_OK, main
from hbtp.domains import Scenario
from hbtp.errors import BackendError, InputError, PddlError
from hbtp.files import InputKind, open_output, read_bytes, read_text, write_all_atomically
from hbtp.llm.backend import Request
from hbtp.llm.backends.oracle import OracleBackend
from hbtp.llm.backends.replay import RecordingBackend
from helpers import cli as run
from helpers import one_error_line

GOAL = "On_Coffee_Table1"
SECRET = "root:x:0:0:a secret line that must never be echoed"


# ----------------------------------------------------------------------------- targets
def _fifo(folder: Path) -> Path:
    path = folder / "fifo"
    os.mkfifo(path)
    return path


def _symlink(folder: Path) -> Path:
    victim = folder / "victim.txt"
    victim.write_text("keep me\n", encoding="utf-8")
    link = folder / "link"
    link.symlink_to(victim)
    return link


def _dangling_symlink(folder: Path) -> Path:
    link = folder / "dangling"
    link.symlink_to(folder / "created-through-the-link")
    return link


def _folder(folder: Path) -> Path:
    path = folder / "a-folder"
    path.mkdir()
    return path


def _null_device(folder: Path) -> Path:
    path = folder / "null"
    try:  # the character device of /dev/null (1, 3), made here: nothing real is ever written
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, OSError) as error:
        pytest.skip(f"cannot make a device node here: {error}")
    return path


TARGETS: dict[str, Callable[[Path], Path]] = {
    "fifo": _fifo,
    "symlink": _symlink,
    "dangling-symlink": _dangling_symlink,
    "folder": _folder,
    "device": _null_device,
}


def _fingerprint(path: Path) -> tuple[int, int, str | None]:
    info = os.lstat(path)
    target = os.readlink(path) if stat.S_ISLNK(info.st_mode) else None
    return info.st_mode, info.st_ino, target


def _untouched(folder: Path, target: Path, before: tuple[int, int, str | None]) -> None:
    assert _fingerprint(target) == before, "the special file was replaced"
    victim = folder / "victim.txt"
    if victim.exists():
        assert victim.read_text(encoding="utf-8") == "keep me\n"
    assert not (folder / "created-through-the-link").exists()
    assert not [name for name in os.listdir(folder) if name.startswith(".")], "a temporary file was left behind"


@pytest.fixture(scope="module")
def tree_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("tree") / "tree.json"
    assert main(["plan", "-s", "robowaiter", "-g", GOAL, "-o", str(path)]) == EXIT_OK
    return path


def _commands(tree: Path, target: str) -> dict[str, list[str]]:
    return {
        "plan -o": ["plan", "-s", "robowaiter", "-g", GOAL, "-o", target],
        "plan --export": ["plan", "-s", "robowaiter", "-g", GOAL, "--export", target, "--format", "json"],
        "plan --record": ["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "oracle", "--record", target],
        "run --trace": ["run", str(tree), "--trace", target],
        "run --btlog": ["run", str(tree), "--engine", "btcpp", "--btlog", target],
        "view -o": ["view", str(tree), "-o", target],
        "export -o": ["export", str(tree), "-o", target, "-f", "json"],
        "dataset convert": ["dataset", "convert", "table2_robowaiter_50", target],
        "dataset generate -o": ["dataset", "generate", "-s", "robowaiter", "-n", "1", "--seed", "1", "-o", target],
        "examples generate -o": ["examples", "generate", "-s", "robowaiter", "-n", "1", "--seed", "1", "-o", target],
        "validate-optimal -o": ["validate-optimal", "-o", target],
    }


COMMANDS = list(_commands(Path("t"), "x"))


@pytest.mark.parametrize("kind", list(TARGETS))
@pytest.mark.parametrize("command", COMMANDS)
def test_every_output_refuses_a_target_that_is_not_a_regular_file(
    command: str, kind: str, tmp_path: Path, tree_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = TARGETS[kind](tmp_path)
    before = _fingerprint(target)
    code, _, err = run(capsys, *_commands(tree_file, str(target))[command])
    assert code == EXIT_INPUT, (command, err)
    line = one_error_line(err)
    if "symlink" in kind:
        assert f"cannot write {target}" in line
        assert "symbolic link" in line
    elif kind == "folder":  # click's own check of a file option comes first for a folder
        assert str(target) in line
        assert "is a directory" in line or "it is a folder" in line
    else:
        assert f"cannot write {target}" in line
        assert "hbtp writes only regular files" in line
    _untouched(tmp_path, target, before)


@pytest.mark.parametrize("command", COMMANDS)
def test_every_output_refuses_a_missing_folder(
    command: str, tmp_path: Path, tree_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "no" / "such" / "folder" / "out.json"
    code, _, err = run(capsys, *_commands(tree_file, str(target))[command])
    assert code == EXIT_INPUT, (command, err)
    assert f"the folder {target.parent} does not exist" in one_error_line(err)
    assert not (tmp_path / "no").exists()


def test_export_pddl_documents_that_it_creates_its_output_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "new" / "pddl"
    code, _, err = run(capsys, "export-pddl", "-s", "robowaiter", "-g", GOAL, "-o", str(folder))
    assert code == EXIT_OK, err
    assert sorted(path.name for path in folder.iterdir()) == ["domain.pddl", "problem.pddl"]
    code, help_text, _ = run(capsys, "export-pddl", "--help")
    assert "created if missing" in help_text
    # ... but never writes through a symbolic link inside it.
    (folder / "domain.pddl").unlink()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n", encoding="utf-8")
    (folder / "domain.pddl").symlink_to(victim)
    code, _, err = run(capsys, "export-pddl", "-s", "robowaiter", "-g", GOAL, "-o", str(folder))
    assert code == EXIT_INPUT
    assert "symbolic link" in one_error_line(err)
    assert victim.read_text(encoding="utf-8") == "keep me\n"


@pytest.mark.parametrize("kind", list(TARGETS))
def test_the_writers_check_the_target_again_when_they_write(kind: str, tmp_path: Path) -> None:
    # The options check the target before any work; the writers check it again (a target can be
    # swapped for a special file while a long search runs).
    target = TARGETS[kind](tmp_path)
    before = _fingerprint(target)
    with pytest.raises(InputError, match=f"cannot write {target}"):
        write_all_atomically({tmp_path / "fine.txt": "a", target: "b"})
    assert not (tmp_path / "fine.txt").exists(), "all or nothing"
    with pytest.raises(InputError, match=f"cannot write {target}"):
        open_output(target, append=True)
    with pytest.raises(InputError, match=f"cannot write {target}"):
        open_output(target)
    _untouched(tmp_path, target, before)


@dataclass(frozen=True, kw_only=True)
class IdRow(Row):
    """A benchmark row of one field, its key."""

    KEY = ("id",)
    id: int


def test_a_benchmark_folder_may_be_created_but_its_files_are_regular(tmp_path: Path) -> None:
    out = tmp_path / "bench" / "run"
    results = ResultsFile(out / "results.jsonl", IdRow)
    results.append(IdRow(id=1))  # the folder is created (bench -o DIR documents it)
    write_json(out / "summary.json", {"a": 1})
    assert json.loads((out / "summary.json").read_text(encoding="utf-8")) == {"a": 1}
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me\n", encoding="utf-8")
    (out / "report.json").symlink_to(victim)
    with pytest.raises(InputError, match="symbolic link"):
        write_json(out / "report.json", {"b": 2})
    (out / "results.jsonl").unlink()
    (out / "results.jsonl").symlink_to(victim)
    with pytest.raises(InputError, match="symbolic link"):
        results.append(IdRow(id=2))
    assert victim.read_text(encoding="utf-8") == "keep me\n"


def test_the_record_file_is_a_regular_file(tmp_path: Path, robowaiter: Scenario) -> None:
    fifo = _fifo(tmp_path)
    with pytest.raises(BackendError, match="it is a FIFO"):  # it is read first: replies recorded before
        RecordingBackend(OracleBackend(robowaiter), fifo)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    record = tmp_path / "record.jsonl"
    recorder = RecordingBackend(OracleBackend(robowaiter), record)
    os.mkfifo(tmp_path / "swapped")
    os.replace(tmp_path / "swapped", record)
    with pytest.raises(BackendError, match="hbtp writes only regular files"):  # swapped after the start
        recorder.complete(Request(messages=(), completion_prompt="Goal: x\n", goal=GOAL))
    assert stat.S_ISFIFO(os.lstat(record).st_mode)


# ----------------------------------------------------------------------------- tree files and paths
def _tree_with_pddl(folder: Path, tree_file: Path, record: dict[str, str]) -> Path:
    document = json.loads(tree_file.read_text(encoding="utf-8"))
    document["pddl"] = record
    path = folder / "tree.json"
    path.write_text(json.dumps(document), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    "record",
    [
        {"domain": "/etc/passwd", "problem": "/etc/passwd"},
        {"domain": "../../etc/shadow", "problem": "problem.pddl"},
        {"domain": "domain.pddl", "problem": "escape/problem.pddl"},  # a symbolic link out of the folder
        {"domain": "domain.pddl", "problem": "problem.pddl", "mutex": "../mutex.toml"},
    ],
)
@pytest.mark.parametrize("command", ["run", "verify", "view", "export"])
def test_a_tree_file_cannot_make_hbtp_open_a_path_outside_its_folder(
    record: dict[str, str], command: str, tmp_path: Path, tree_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "trees"
    folder.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "problem.pddl").write_text(SECRET, encoding="utf-8")
    (tmp_path / "mutex.toml").write_text(SECRET, encoding="utf-8")
    (folder / "escape").symlink_to(outside)
    (folder / "domain.pddl").write_text(SECRET, encoding="utf-8")
    (folder / "problem.pddl").write_text(SECRET, encoding="utf-8")
    tree = _tree_with_pddl(folder, tree_file, record)
    extra = {"view": ["-o", str(tmp_path / "page.html")], "export": ["-f", "text"]}.get(command, [])
    code, out, err = run(capsys, command, str(tree), *extra)
    assert code == EXIT_INPUT, err
    line = one_error_line(err)
    assert "outside the tree file's folder" in line
    assert "give --pddl DOMAIN PROBLEM" in line
    assert "secret" not in line + out


def test_recorded_pddl_inside_the_tree_folder_is_read_relative_to_the_tree(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from hbtp.domains import load_scenario

    shipped = load_scenario("robowaiter")
    folder = tmp_path / "bundle"
    (folder / "pddl").mkdir(parents=True)
    for name, source in (("domain.pddl", shipped.domain_file), ("problem.pddl", shipped.problem_file)):
        (folder / "pddl" / name).write_bytes(Path(source).read_bytes())
    tree = folder / "tree.json"
    domain, problem = str(folder / "pddl" / "domain.pddl"), str(folder / "pddl" / "problem.pddl")
    code, _, err = run(capsys, "plan", "--pddl", domain, problem, "-g", GOAL, "-o", str(tree))
    assert code == EXIT_OK, err
    assert json.loads(tree.read_text(encoding="utf-8"))["pddl"]["domain"] == "pddl/domain.pddl"
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    os.chdir(elsewhere)  # paths are relative to the tree file, not to the working folder
    try:
        code, _, err = run(capsys, "verify", str(tree))
    finally:
        os.chdir(tmp_path)
    assert code == EXIT_OK, err


# ----------------------------------------------------------------------------- bounded reads
@pytest.mark.parametrize("option", ["-g", "-i"])
def test_a_goal_or_instruction_file_that_is_not_a_regular_file_is_refused(
    option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = _fifo(tmp_path)  # no writer: reading it would wait for ever
    code, _, err = run(capsys, "plan", "-s", "robowaiter", option, f"@{fifo}", "--llm", "oracle")
    assert code == EXIT_INPUT
    assert "it is a FIFO" in one_error_line(err)


@pytest.mark.parametrize("option", ["-g", "-i"])
def test_a_goal_or_instruction_larger_than_its_cap_is_refused_naming_the_cap(
    option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    big = tmp_path / "goal.txt"
    big.write_bytes(b"On_Coffee_Table1 & " * (InputKind.GOAL.cap // 19 + 1))
    code, _, err = run(capsys, "plan", "-s", "robowaiter", option, f"@{big}", "--llm", "oracle")
    assert code == EXIT_INPUT
    assert "larger than the limit of 1 MiB" in one_error_line(err)


def test_standard_input_is_read_under_the_same_cap(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    class Endless(io.RawIOBase):  # a stream that never ends, like `-g @- < /dev/zero`
        def readable(self) -> bool:
            return True

        def readinto(self, buffer: bytearray) -> int:  # type: ignore[override]
            buffer[:] = b"a" * len(buffer)
            return len(buffer)

    stream = io.TextIOWrapper(io.BufferedReader(Endless()))
    monkeypatch.setattr(sys, "stdin", stream)
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", "@-")
    assert code == EXIT_INPUT
    assert "standard input: the goal is larger than the limit of 1 MiB" in one_error_line(err)


@pytest.mark.parametrize("command", ["plan", "ground"])
def test_pddl_inputs_must_be_regular_files_within_the_cap(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fifo = _fifo(tmp_path)
    extra = ["-g", "p"] if command == "plan" else []
    code, _, err = run(capsys, command, "--pddl", str(fifo), str(fifo), *extra)
    assert code == EXIT_INPUT
    assert f"{fifo}: cannot read the PDDL file: it is a FIFO" in one_error_line(err)
    sparse = tmp_path / "huge.pddl"
    with sparse.open("wb") as handle:  # sparse: no disk space, but a size past the cap
        handle.truncate(InputKind.PDDL.cap + 1)
    code, _, err = run(capsys, command, "--pddl", str(sparse), str(sparse), *extra)
    assert code == EXIT_INPUT
    assert "the PDDL file is larger than the limit of 64 MiB" in one_error_line(err)


@pytest.mark.parametrize(
    ("argv", "kind"),
    [
        (["run", "{x}"], "tree file"),
        (["verify", "{x}"], "tree file"),
        (["view", "{tree}", "--trace", "{x}", "-o", "{out}"], "trace"),
        (["plan", "-s", "robowaiter", "-g", GOAL, "--hints", "{x}"], "hints file"),
        (["plan", "-s", "robowaiter", "-g", GOAL, "--llm", "replay:{x}"], "record file"),
        (["dataset", "validate", "{x}", "-s", "robowaiter"], "dataset file"),
        (["plan", "--pddl", "{domain}", "{problem}", "--mutex", "{x}", "-g", GOAL], "settings file"),
    ],
)
def test_every_input_file_must_be_a_regular_file(
    argv: list[str], kind: str, tmp_path: Path, tree_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from hbtp.domains import load_scenario

    shipped = load_scenario("robowaiter")
    fifo = _fifo(tmp_path)
    values = {
        "x": str(fifo),
        "tree": str(tree_file),
        "out": str(tmp_path / "page.html"),
        "domain": str(shipped.domain_file),
        "problem": str(shipped.problem_file),
    }
    code, _, err = run(capsys, *[item.format(**values) for item in argv])
    assert code == EXIT_INPUT, err
    assert f"cannot read the {kind}: it is a FIFO" in one_error_line(err)


def test_read_bytes_caps_a_file_that_claims_a_small_size(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # /proc files claim size 0 and may be endless: the read itself stops one byte past the cap.
    path = tmp_path / "grows.txt"
    path.write_bytes(b"x" * (InputKind.GOAL.cap + 10))
    real_fstat = os.fstat

    def claims_empty(descriptor: int) -> os.stat_result:
        info = real_fstat(descriptor)
        return os.stat_result((info.st_mode, *info[1:6], 0, *info[7:]))

    monkeypatch.setattr("hbtp.files.os.fstat", claims_empty)
    with pytest.raises(InputError, match="larger than the limit of 1 MiB"):
        read_bytes(path, InputKind.GOAL)


def test_bad_utf8_names_its_line_column_and_byte(tmp_path: Path) -> None:
    path = tmp_path / "domain.pddl"
    path.write_bytes(b"(define (domain d)\n  (:predicates (p\xff)))\n")
    with pytest.raises(InputError) as caught:
        read_text(path, InputKind.PDDL)
    assert str(caught.value) == f"{path}:2:18: the PDDL file is not UTF-8 text (byte 36)"
    from hbtp.domains.pddl_reader import read_domain_file

    with pytest.raises(PddlError) as pddl_error:
        read_domain_file(path)
    assert (pddl_error.value.line, pddl_error.value.column) == (2, 18)


# ----------------------------------------------------------------------------- memory
GROWING_DOMAIN = """\
(define (domain cube)
  (:requirements :strips)
  (:predicates (p ?x ?y ?z) (q))
  (:action a :parameters (?x ?y ?z) :precondition (q) :effect (p ?x ?y ?z)))
"""


def test_memory_mb_bounds_the_whole_command_from_its_start(tmp_path: Path) -> None:
    # Grounding 8 million actions needs gigabytes; with --memory-mb 300 it must stop at the limit
    # while grounding (before any search), in one line, exit 1, in its own process.
    (tmp_path / "d.pddl").write_text(GROWING_DOMAIN, encoding="utf-8")
    names = " ".join(f"o{i}" for i in range(200))
    problem = f"(define (problem p) (:domain cube) (:objects {names}) (:init (q)) (:goal (p o1 o2 o3)))"
    (tmp_path / "p.pddl").write_text(problem, encoding="utf-8")
    argv = ["plan", "--pddl", "d.pddl", "p.pddl", "-g", "p(o1,o2,o3)", "--memory-mb", "300", "-t", "120"]
    env = {**os.environ, "HBTP_MAX_GROUND_ACTIONS": "100000000"}
    code = "import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (6 * 2**30, 6 * 2**30)); "
    code += "from hbtp.cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run(
        [sys.executable, "-c", code, *argv], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == EXIT_NOT_SOLVED, done.stderr
    assert done.stderr.startswith("hbtp: error: memory limit of 300 MB reached"), done.stderr
    assert done.stderr.count("\n") == 1, done.stderr


def test_memory_mb_restores_the_limit_after_an_in_process_command(capsys: pytest.CaptureFixture[str]) -> None:
    before = resource.getrlimit(resource.RLIMIT_DATA)
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--memory-mb", "100000")
    assert code == EXIT_OK, err
    assert resource.getrlimit(resource.RLIMIT_DATA) == before


@pytest.mark.parametrize("value", ["0", "-5", "nan", "inf"])
def test_memory_mb_must_be_a_positive_finite_number(value: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plan", "-s", "robowaiter", "-g", GOAL, "--memory-mb", value)
    assert code == EXIT_INPUT
    assert "memory limit must be a positive number of MB" in one_error_line(err)
