"""``--mutex FILE``: declared mutexes read from TOML; a malformed file is a one-line input error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hbtp.cli import EXIT_INPUT, EXIT_OK, main
from hbtp.domains.scenarios import DATA, read_mutex_file
from hbtp.errors import InputError

DOMAIN = Path(str(DATA / "robowaiter.domain.pddl"))
PROBLEM = Path(str(DATA / "robowaiter.problem.pddl"))

BAD_SHAPES = {
    "groups a number": "groups = 5\n",
    "groups a text": 'groups = "RobotNear(*)"\n',
    "groups a flat list": 'groups = ["RobotNear(*)"]\n',
    "groups a table": "[groups]\na = 1\n",
    "an atom a number": "groups = [[1, 2]]\n",
    "an atom a list": 'groups = [[["RobotNear(*)"]]]\n',
    "nogoods a number": "nogoods = 5\n",
    "nogoods of tables": "nogoods = [{a = 1}]\n",
    "nogoods with a boolean": 'nogoods = [["Holding(Coffee)", true]]\n',
}


@pytest.mark.parametrize("text", BAD_SHAPES.values(), ids=BAD_SHAPES)
def test_groups_and_nogoods_must_be_lists_of_lists_of_text(text: str, tmp_path: Path) -> None:
    path = tmp_path / "mutex.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match="must be a list of lists of atoms"):
        read_mutex_file(path)


def test_well_formed_file(tmp_path: Path) -> None:
    path = tmp_path / "mutex.toml"
    nogood = ["Holding(Coffee)", "Holding(Water)"]
    path.write_text(f'groups = [["RobotNear(*)"]]\nnogoods = [{json.dumps(nogood)}]\n', encoding="utf-8")
    assert read_mutex_file(path) == {"groups": [["RobotNear(*)"]], "nogoods": [nogood]}
    path.write_text("", encoding="utf-8")
    assert read_mutex_file(path) == {"groups": [], "nogoods": []}


def test_non_utf8_file_is_an_input_error(tmp_path: Path) -> None:
    path = tmp_path / "mutex.toml"
    path.write_bytes(b'groups = [["\xff"]]\n')
    with pytest.raises(InputError, match="not UTF-8"):
        read_mutex_file(path)


def _plan(capsys: pytest.CaptureFixture[str], mutex_file: Path) -> tuple[int, str, str]:
    code = main(["plan", "--pddl", str(DOMAIN), str(PROBLEM), "--mutex", str(mutex_file), "-g", "On_Coffee_Table1"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("content", [b"groups = 5\n", b'nogoods = [[1, "x"]]\n', b'groups = [["\xff"]]\n'])
def test_cli_reports_a_bad_mutex_file_in_one_line(
    content: bytes, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    code, _, err = _plan(capsys, path)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == EXIT_INPUT, err
    assert len(lines) == 1, err
    assert lines[0].startswith(f"hbtp: error: {path}:")
    assert "internal error" not in err
    assert "Traceback" not in err


def test_cli_plans_with_a_good_mutex_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "good.toml"
    path.write_text('groups = [["RobotNear(*)"]]\n', encoding="utf-8")
    code, out, err = _plan(capsys, path)
    assert code == EXIT_OK, err
    assert out.strip()
