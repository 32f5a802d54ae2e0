"""Lint and type checks run with the tests, so CI and the README command both enforce them."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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


# The package's layers, lowest first (docs/architecture.md): a module may import its own layer and
# the layers below it, never one above.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("__init__", "errors", "files", "memory", "deadline", "collector", "compiled"),
    ("logic",),
    ("domains",),
    ("datasets",),
    ("planning",),
    ("bt",),
    ("llm",),
    ("pipeline", "runtime"),
    ("bench", "validation"),
    ("cli", "__main__"),
)


def _layer(part: str) -> int:
    for rank, names in enumerate(LAYERS):
        if part in names:
            return rank
    raise AssertionError(f"hbtp.{part} has no layer in LAYERS (tests/test_quality.py, docs/architecture.md)")


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
