"""Every data file of the package is covered by pyproject's package-data, so pip users get it."""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_every_data_file_is_package_data() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = config["tool"]["setuptools"]["package-data"]["hbtp"]
    package = ROOT / "src" / "hbtp"
    data_files = [p for p in package.rglob("*") if p.is_file() and "data" in p.relative_to(package).parts]
    assert data_files, "no data files found"
    missing = [
        str(p.relative_to(package))
        for p in data_files
        if not any(fnmatch.fnmatch(str(p.relative_to(package)), pattern) for pattern in patterns)
    ]
    assert not missing, f"not shipped in the wheel: {missing}"
