"""Lint and type checks run with the tests, so CI and the README command both enforce them."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _tool(name: str) -> str:
    found = shutil.which(name, path=str(Path(sys.executable).parent)) or shutil.which(name)
    if found is None:
        pytest.fail(f"{name} is not installed: install the dev extra (pip install -e '.[dev]')")
    return found


def test_ruff_lint_and_format() -> None:
    ruff = _tool("ruff")
    lint = subprocess.run([ruff, "check", "src", "tests", "examples"], cwd=ROOT, capture_output=True, text=True)
    assert lint.returncode == 0, lint.stdout + lint.stderr
    fmt = subprocess.run(
        [ruff, "format", "--check", "src", "tests", "examples"], cwd=ROOT, capture_output=True, text=True
    )
    assert fmt.returncode == 0, fmt.stdout + fmt.stderr


def test_mypy_strict_on_the_package() -> None:
    mypy = _tool("mypy")
    result = subprocess.run([mypy], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


MAX_FUNCTION_LINES = 60
MAX_PARAMETERS = 10


def _functions(path: Path) -> list[tuple[str, int, int, int]]:
    """(name, line, body lines, parameters) of every function in ``path`` (``self``/``cls`` not counted)."""
    import ast

    found: list[tuple[str, int, int, int]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            arguments = node.args
            names = [a.arg for a in (*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs)]
            names += [a.arg for a in (arguments.vararg, arguments.kwarg) if a is not None]
            count = len(names) - (1 if names[:1] in (["self"], ["cls"]) else 0)
            lines = (node.end_lineno or node.lineno) - node.lineno + 1
            found.append((node.name, node.lineno, lines, count))
    return found


def test_functions_are_short_and_take_few_parameters() -> None:
    """The consolidation's size rule: no function over 60 lines or with more than 10 parameters
    (a command's options travel as one dataclass)."""
    offenders = [
        f"{path.relative_to(ROOT)}:{line} {name}: {lines} lines, {count} parameters"
        for path in sorted((ROOT / "src" / "hbtp").rglob("*.py"))
        for name, line, lines, count in _functions(path)
        if lines > MAX_FUNCTION_LINES or count > MAX_PARAMETERS
    ]
    assert not offenders, "\n".join(offenders)


MAX_MODULE_LINES = 600
MAX_CLASS_LINES = 300
MAX_CLASS_METHODS = 25


def test_modules_and_classes_stay_small() -> None:
    """No module over 600 lines; no class over 300 lines or 25 methods (one job each)."""
    import ast

    offenders: list[str] = []
    for path in sorted((ROOT / "src" / "hbtp").rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        where = path.relative_to(ROOT)
        if text.count("\n") > MAX_MODULE_LINES:
            offenders.append(f"{where}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ClassDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                methods = sum(isinstance(item, ast.FunctionDef | ast.AsyncFunctionDef) for item in node.body)
                if lines > MAX_CLASS_LINES or methods > MAX_CLASS_METHODS:
                    offenders.append(f"{where}:{node.lineno} class {node.name}: {lines} lines, {methods} methods")
    assert not offenders, "\n".join(offenders)


# The package's layers, lowest first (docs/architecture.md): a module may import its own layer and
# the layers below it, never one above.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("__init__", "errors", "files", "memory", "deadline", "collector", "compiled", "pacing"),
    ("logic",),
    ("domains",),
    ("datasets",),
    ("planning",),
    ("bt",),
    ("llm",),
    ("pipeline", "runtime", "replanning", "implementations"),
    ("bench", "validation", "train"),
    ("cli", "__main__"),
)


def _layer(part: str) -> int:
    for rank, names in enumerate(LAYERS):
        if part in names:
            return rank
    raise AssertionError(f"hbtp.{part} has no layer in LAYERS (tests/project/test_quality.py, docs/architecture.md)")


def test_imports_point_down_the_layers() -> None:
    import ast

    upward: list[str] = []
    package = ROOT / "src" / "hbtp"
    for path in sorted(package.rglob("*.py")):
        parts = path.relative_to(package).with_suffix("").parts
        rank = _layer(parts[0])
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            modules = (
                [node.module]
                if isinstance(node, ast.ImportFrom) and node.module and node.level == 0
                else [alias.name for alias in node.names]
                if isinstance(node, ast.Import)
                else []
            )
            for module in modules:
                pieces = module.split(".")
                if pieces[0] == "hbtp" and len(pieces) > 1 and _layer(pieces[1]) > rank:
                    upward.append(f"{path.relative_to(ROOT)}:{node.lineno} imports {module}")
    assert not upward, "\n".join(upward)


def test_docs_architecture_names_every_module() -> None:
    # Each module of the package is named (in backticks) in docs/architecture.md's table.
    import re

    doc = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    named = set(re.findall(r"`([^`]+)`", doc))
    words = {word for entry in named for word in re.split(r"[^A-Za-z0-9_]+", entry) if word}
    package = ROOT / "src" / "hbtp"
    missing = [
        str(path.relative_to(package))
        for path in sorted(package.rglob("*.py"))
        if path.stem not in ("__init__", "__main__") and path.stem not in words
    ]
    assert missing == [], f"docs/architecture.md does not name: {missing}"


#: The module-level mutable state the package keeps, each with its owner and bound. Anything else
#: (a module-level dict, list or set, or an unbounded functools.cache) fails the test below.
KEPT_STATE = {
    "compiled.py:_warned": "one entry per optional C extension (four)",
    "llm/redact.py:_secrets": "the secrets to redact, at most MAX_SECRETS",
    "bench/table2.py:_BACKENDS": "a worker's backends, at most BACKENDS_KEPT",
    "bench/payoff.py:_BACKEND": "a worker's one backend",
    "bt/pytrees_export.py:cache": "one table of the BT.CPP names, computed once",
    "domains/scenarios.py:cache": "the manifest of the shipped scenarios, read once",
    "datasets/shipped.py:cache": "the shipped datasets' names and records (a fixed, shipped set)",
    "datasets/instructions.py:cache": "the shipped instruction datasets (a fixed, shipped set)",
}


_MUTATORS = {
    "append",
    "add",
    "update",
    "pop",
    "popitem",
    "clear",
    "setdefault",
    "extend",
    "insert",
    "remove",
    "discard",
}


def _mutated_names(tree: object) -> set[str]:
    """The names a module changes in place: ``X[k] = v``, ``del X[k]``, ``X.append(...)`` and the like."""
    import ast

    names: set[str] = set()
    for node in ast.walk(tree):  # type: ignore[arg-type]
        targets = node.targets if isinstance(node, ast.Assign | ast.Delete) else [getattr(node, "target", None)]
        for target in targets:
            if isinstance(target, ast.Subscript) and isinstance(target.value, ast.Name):
                names.add(target.value.id)
        call = node.func if isinstance(node, ast.Call) else None
        if isinstance(call, ast.Attribute) and call.attr in _MUTATORS and isinstance(call.value, ast.Name):
            names.add(call.value.id)
    return names


def test_module_level_state_has_an_owner_and_a_bound() -> None:
    # A module-level dict, list or set that its module changes, or an unbounded cache, is process-
    # wide state: it must be listed in KEPT_STATE with its owner and bound (constant tables pass).
    import ast

    package = ROOT / "src" / "hbtp"
    found: list[str] = []
    for path in sorted(package.rglob("*.py")):
        where = path.relative_to(package).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        mutated = _mutated_names(tree)
        for node in tree.body:
            target = node.targets[0] if isinstance(node, ast.Assign) else getattr(node, "target", None)
            value = getattr(node, "value", None)
            mutable = isinstance(value, ast.Dict | ast.List | ast.Set) or (
                isinstance(value, ast.Call) and getattr(value.func, "id", "") in ("dict", "list", "set")
            )
            if isinstance(target, ast.Name) and mutable and target.id in mutated:
                found.append(f"{where}:{target.id}")
            if isinstance(node, ast.FunctionDef):
                for decorator in node.decorator_list:
                    if ast.unparse(decorator) in ("functools.cache", "cache", "functools.lru_cache(maxsize=None)"):
                        found.append(f"{where}:cache")
    assert sorted(set(found) - set(KEPT_STATE)) == [], "module-level state without an owner and a bound"


def test_tests_do_not_print() -> None:
    offenders = []
    for path in sorted((ROOT / "tests").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert offenders == []
