"""hbtp.datasets: the two file formats, the shipped files, and validation against the scenarios."""

from __future__ import annotations

import dataclasses
import json
from collections import Counter
from pathlib import Path

import pytest

from hbtp.datasets import (
    DATASET_SCENARIO,
    OptimalCost,
    Record,
    Severity,
    dataset_names,
    dataset_path,
    load_dataset,
    read_dataset_file,
    read_jsonl,
    read_jsonl_file,
    read_text,
    read_text_file,
    validate_dataset,
    validate_records,
    write_jsonl,
    write_text,
)
from hbtp.domains import load_scenario
from hbtp.errors import DatasetError, InputError

SIZES = {
    "table1_robothow_100": 100,
    "table2_robowaiter_50": 50,
    "table2_virtualhome_50": 50,
    "table2_robothow_small_50": 50,
    "table2_robothow_50": 50,
    "fewshot_robowaiter_100": 63,
    "fewshot_virtualhome_100": 100,
    "fewshot_robothow_small_100": 100,
    "fewshot_robothow_100": 100,
}

TWO_RECORDS = """\
1
Environment:1
Instruction: Put the milk away.
Goals: IsIn_milk_fridge & IsClose_fridge
Optimal Actions: Walk_milk, RightGrab_milk
Vital Action Predicates: Walk, RightGrab
Vital Objects: milk, fridge
cost: 12

2
Environment:1
Instruction:\x20
Goals: IsOn_chips_desk
Optimal Actions: Walk_chips
Vital Action Predicates: Walk
Vital Objects: chips
"""

# ------------------------------------------------------------------ shipped files


def test_shipped_names_sizes_and_scenarios() -> None:
    assert dataset_names() == tuple(SIZES)
    assert tuple(DATASET_SCENARIO) == dataset_names()
    assert DATASET_SCENARIO["fewshot_robothow_small_100"] == "robothow-small"
    assert DATASET_SCENARIO["table2_robothow_small_50"] == "robothow-small"
    for name, size in SIZES.items():
        assert dataset_path(name).is_file()
        records = load_dataset(name)
        assert len(records) == size
        numbers = [int(r.id) for r in records]
        assert numbers == sorted(set(numbers))  # the RoboWaiter files skip some ids
        if "robowaiter" not in name:
            assert numbers == list(range(1, size + 1))


def test_unknown_dataset_names_the_choices() -> None:
    with pytest.raises(InputError, match="table2_robowaiter_50"):
        load_dataset("table3")
    with pytest.raises(InputError, match="unknown dataset"):
        dataset_path("nope")


def test_load_dataset_returns_a_fresh_list() -> None:
    records = load_dataset("table2_robowaiter_50")
    records.clear()
    assert len(load_dataset("table2_robowaiter_50")) == 50


@pytest.mark.parametrize("name", list(SIZES))
def test_text_round_trip_reproduces_the_file(name: str) -> None:
    text = dataset_path(name).read_text(encoding="utf-8")
    records = read_text(text, name)
    written = write_text(records)
    assert read_text(written) == records
    # byte for byte, except that the writer always ends with exactly one newline
    assert written == text.rstrip("\n") + "\n"


@pytest.mark.parametrize("name", list(SIZES))
def test_jsonl_round_trip(name: str) -> None:
    records = load_dataset(name)
    written = write_jsonl(records)
    assert written.count("\n") == len(records)
    again = read_jsonl(written)
    assert again == records
    assert [r.line for r in again] == list(range(1, len(records) + 1))
    assert write_text(again) == write_text(records)


def test_record_lines_point_at_the_id_line() -> None:
    text = dataset_path("table1_robothow_100").read_text(encoding="utf-8")
    lines = text.split("\n")
    for record in load_dataset("table1_robothow_100"):
        assert lines[record.line - 1] == record.id


def test_verbatim_fields_of_the_shipped_files() -> None:
    waiter = load_dataset("table2_robowaiter_50")[0]
    assert waiter.instruction == " "  # "Instruction:  " in the file
    assert waiter.environment == "1"
    assert waiter.cost is None
    table1 = load_dataset("table1_robothow_100")[0]
    assert table1.instruction == "Put the bag of chips on the corner of my desk."
    assert table1.optimal_actions == ("Walk_chips", "RightGrab_chips", "Walk_desk", "RightPut_chips_desk")
    assert table1.vital_predicates == ("Walk", "RightGrab", "RightPut")
    assert table1.vital_objects == ("chips", "desk")
    fewshot = load_dataset("fewshot_robowaiter_100")[2]
    assert (fewshot.goal, fewshot.cost) == ("On_Water_Table1", 57)


def test_empty_optimal_actions_are_an_empty_tuple() -> None:
    records = {r.id: r for r in load_dataset("table2_virtualhome_50")}
    for record_id in ("11", "18"):
        assert records[record_id].optimal_actions == ()
        assert records[record_id].vital_predicates == ()
        assert records[record_id].vital_objects == ()


# ------------------------------------------------------------------ records and formats


def test_record_dict_round_trip_and_line_not_compared() -> None:
    record = Record("7", "IsOn_a_b", ("Walk_a",), ("Walk",), ("a", "b"), instruction="Do it.", cost=3, line=9)
    data = record.to_dict()
    assert "line" not in data
    assert json.loads(json.dumps(data)) == data
    assert Record.from_dict(data) == record
    assert Record.from_dict(data).line == 0
    assert "cost" not in dataclasses.replace(record, cost=None).to_dict()


def test_read_text_small() -> None:
    first, second = read_text(TWO_RECORDS, "t.txt")
    assert first == Record(
        "1",
        "IsIn_milk_fridge & IsClose_fridge",
        ("Walk_milk", "RightGrab_milk"),
        ("Walk", "RightGrab"),
        ("milk", "fridge"),
        instruction="Put the milk away.",
        cost=12,
    )
    assert (first.line, second.line) == (1, 10)
    assert second.instruction == ""
    assert second.cost is None
    assert write_text([first, second]) == TWO_RECORDS


def test_read_text_is_lenient_about_layout() -> None:
    text = (
        "\ufeff\n\n5\r\nGoals: IsOn_a_b\r\nVital Objects:\r\nOptimal Actions:\r\n"
        "Vital Action Predicates: \r\n  \n\n\n6\nGoals: IsOn_c_d\nOptimal Actions: Walk_c\n"
        "Vital Action Predicates: Walk\nVital Objects: c\n"
    )
    five, six = read_text(text)
    assert five == Record("5", "IsOn_a_b", (), (), ())
    assert (five.line, six.line) == (3, 11)
    assert six.environment == "1"


def test_read_text_empty() -> None:
    assert read_text("") == []
    assert read_text("\n \n") == []
    assert write_text([]) == ""


BROKEN = [
    # (replace this text of record 2, by this, expected line, message fragment); record 2 starts at line 10
    ("Goals: IsOn_chips_desk\n", "", 10, "missing 'Goals:' line"),
    ("Vital Objects: chips\n", "", 10, "missing 'Vital Objects:' line"),
    ("Instruction: ", "Instructions: go", 12, "unknown key 'Instructions'"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: twelve", 17, "cost must be a non-negative integer"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: -3", 17, "cost must be a non-negative integer"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: \u0663", 17, "in ASCII digits, got '\u0663'"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: \uff13", 17, "in ASCII digits"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: 1_0", 17, "in ASCII digits, got '1_0'"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: " + "9" * 5000, 17, "cost has 5000 digits"),
    ("Vital Objects: chips", "Vital Objects: chips\ncost: 1000000000000000000", 17, "cost has 19 digits"),
    ("Optimal Actions: Walk_chips", "Optimal Actions: Walk_chips\nGoals: IsOn_a_b", 15, "duplicate 'Goals' line"),
    ("Optimal Actions: Walk_chips", "Optimal Actions: Walk_chips\n%%% garbage", 15, "cannot read '%%% garbage'"),
    ("Goals: IsOn_chips_desk", "Goals: IsOn_chips_desk &", 13, "bad goal"),
    ("Goals: IsOn_chips_desk", "Goals:", 13, "empty goal"),
    ("Optimal Actions: Walk_chips", "Optimal Actions: Walk_chips, , Grab_chips", 14, "empty item"),
    ("Optimal Actions: Walk_chips", "Optimal Actions: Walk chips", 14, "malformed name 'Walk chips'"),
    ("Environment:1", "Environment:", 11, "Environment must be one word"),
    ("2\nEnvironment:1", "Environment:1", 10, "expected a record id"),
    ("2\nEnvironment:1", "1\nEnvironment:1", 10, "duplicate record id '1' (first at line 1)"),
]


@pytest.mark.parametrize(("old", "new", "line", "fragment"), BROKEN)
def test_broken_records_raise_dataset_error_at_the_line(old: str, new: str, line: int, fragment: str) -> None:
    head, tail = TWO_RECORDS.split("\n\n")
    assert old in tail
    text = head + "\n\n" + tail.replace(old, new, 1)
    with pytest.raises(DatasetError) as caught:
        read_text(text, "broken.txt")
    error = caught.value
    assert fragment in error.message
    assert (error.source, error.line) == ("broken.txt", line)
    assert str(error).startswith(f"broken.txt:{line}: ")


def test_write_text_refuses_what_it_cannot_read_back() -> None:
    record = Record("1", "IsOn_a_b", (), (), ())
    assert read_text(write_text([record])) == [record]
    for bad in (
        dataclasses.replace(record, instruction="two\nlines"),
        dataclasses.replace(record, vital_objects=("a,b",)),
        dataclasses.replace(record, id="my id"),
        dataclasses.replace(record, goal=""),
    ):
        with pytest.raises(InputError, match="cannot be written"):
            write_text([bad])


def test_verbatim_goal_and_instruction_survive() -> None:
    record = Record("1", " IsOn_a_b ", (), (), (), instruction="  ")
    assert read_text(write_text([record])) == [record]


JSONL_BROKEN = [
    ("{not json", "invalid JSON"),
    ("[1, 2]", "expected a JSON object"),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": []}',
        "missing key(s) 'vital_objects'",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], "x": 1}',
        "unknown key(s) 'x'",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": "Walk_a", "vital_predicates": [], "vital_objects": []}',
        "'optimal_actions' must be a list of strings",
    ),
    (
        '{"id": 9, "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": []}',
        "'id' must be a string",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], '
        '"cost": "3"}',
        "'cost' must be an integer",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], '
        '"cost": true}',
        "'cost' must be an integer",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], '
        '"cost": ' + "9" * 5000 + "}",
        "invalid JSON: a number with too many digits",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], '
        '"cost": 1000000000000000000}',
        "'cost' must be a non-negative integer below 10**18",
    ),
    (
        '{"id": "9", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": [], '
        '"cost": -3}',
        "'cost' must be a non-negative integer",
    ),
    ("[" * 100_000, "invalid JSON: nested too deeply"),
    (
        '{"id": "1", "goal": "IsOn_a_b", "optimal_actions": [], "vital_predicates": [], "vital_objects": []}',
        "duplicate record id '1' (first at line 1)",
    ),
]


@pytest.mark.parametrize(("bad_line", "fragment"), JSONL_BROKEN)
def test_broken_jsonl_raises_dataset_error_at_the_line(bad_line: str, fragment: str) -> None:
    good = write_jsonl(read_text(TWO_RECORDS)).split("\n")
    text = "\n".join([good[0], "", bad_line, good[1]])
    with pytest.raises(DatasetError) as caught:
        read_jsonl(text, "x.jsonl")
    assert fragment in caught.value.message
    assert (caught.value.source, caught.value.line) == ("x.jsonl", 3)


def test_read_dataset_file_chooses_by_extension(tmp_path: Path) -> None:
    records = read_text(TWO_RECORDS)
    (tmp_path / "a.jsonl").write_text(write_jsonl(records), encoding="utf-8")
    (tmp_path / "b.json").write_text(write_jsonl(records), encoding="utf-8")
    (tmp_path / "c.txt").write_text(write_text(records), encoding="utf-8")
    (tmp_path / "d").write_text(write_text(records), encoding="utf-8")
    for name in ("a.jsonl", "b.json", "c.txt", "d"):
        assert read_dataset_file(tmp_path / name) == records
    assert read_jsonl_file(tmp_path / "a.jsonl") == records
    assert read_text_file(tmp_path / "c.txt") == records
    (tmp_path / "e.jsonl").write_text(TWO_RECORDS, encoding="utf-8")
    with pytest.raises(DatasetError, match="expected a JSON object"):
        read_dataset_file(tmp_path / "e.jsonl")


@pytest.mark.parametrize("reader", [read_dataset_file, read_text_file, read_jsonl_file])
def test_unreadable_files_raise_dataset_error(tmp_path: Path, reader: object) -> None:
    assert callable(reader)
    binary = tmp_path / "bad.txt"
    binary.write_bytes(b"1\n\xff\xfe\n")
    for path, fragment in (
        (tmp_path / "missing.txt", "cannot read the dataset file"),
        (tmp_path, "cannot read the dataset file"),
        (binary, "not UTF-8"),
    ):
        with pytest.raises(DatasetError, match=fragment) as caught:
            reader(path)
        assert caught.value.source == str(path)


# ------------------------------------------------------------------ validation

# dataset -> (invalid ids, ids with warnings), from reference_results.md "Known defects"
_SMALL_FEWSHOT_INVALID_NUMBERS = (
    3, 5, 6, 9, 10, 11, 12, 15, 16, 17, 18, 19, 20, 23, 24, 26, 30, 31, 32, 35, 36, 37, 39, 40, 42, 45,
    46, 47, 51, 53, 54, 55, 58, 59, 60, 61, 62, 65, 70, 73, 75, 79, 80, 85, 86, 87, 88, 90, 91, 92, 94, 99,
)  # fmt: skip
SMALL_FEWSHOT_INVALID = tuple(str(i) for i in _SMALL_FEWSHOT_INVALID_NUMBERS)
EXPECTED = {
    "table1_robothow_100": (("29", "99"), ()),
    "table2_robowaiter_50": ((), ()),
    "table2_virtualhome_50": ((), ("11", "18")),
    "table2_robothow_small_50": ((), ()),
    "table2_robothow_50": (("15",), ()),
    "fewshot_robowaiter_100": ((), ()),
    "fewshot_virtualhome_100": ((), ("12", "17", "25", "31", "37", "47", "56")),
    "fewshot_robothow_small_100": (SMALL_FEWSHOT_INVALID, ()),
    "fewshot_robothow_100": ((), ()),
}


@pytest.mark.parametrize("name", list(EXPECTED))
def test_shipped_datasets_report_exactly_the_known_defects(name: str) -> None:
    invalid, warned = EXPECTED[name]
    report = validate_dataset(name)
    assert report.scenario == DATASET_SCENARIO[name]
    assert report.records == SIZES[name]
    assert report.invalid_ids == invalid
    assert report.warning_ids == warned
    assert report.valid is (not invalid)
    assert all(issue.code == "goal-true-in-s0" for issue in report.warnings)
    json.dumps(report.to_dict())


def test_fewshot_robothow_small_fits_robothow() -> None:
    report = validate_dataset("fewshot_robothow_small_100", "robothow")
    assert len(SMALL_FEWSHOT_INVALID) == 52
    assert report.valid
    assert report.issues == ()


def test_fewshot_robothow_small_defects_in_detail() -> None:
    report = validate_dataset("fewshot_robothow_small_100")
    codes: dict[str, set[str]] = {}
    for issue in report.issues:
        codes.setdefault(issue.record_id, set()).add(issue.code)
    # 7 records use only objects the small domain has, but actions it lacks
    only_actions = sorted((i for i, c in codes.items() if c == {"unknown-action"}), key=int)
    assert only_actions == ["3", "36", "40", "55", "59", "85", "87"]
    assert any("Open(garbagecan)" in i.message for i in report.issues if i.record_id == "3")
    # the other 45 use objects it lacks
    assert sum("unknown-object" in c for c in codes.values()) == 45


def test_known_defects_are_explained() -> None:
    table1 = {issue.record_id: issue for issue in validate_dataset("table1_robothow_100").issues}
    assert table1["29"].code == "not-applicable"
    assert "LeftPutIn(chicken,fridge)" in table1["29"].message
    assert "IsNear(self,fridge)" in table1["29"].message
    assert table1["99"].code == "not-applicable"
    assert "RightPutIn(cutlets,box)" in table1["99"].message
    assert "IsNear(self,box)" in table1["99"].message
    (issue,) = validate_dataset("table2_robothow_50").issues
    assert (issue.record_id, issue.code) == ("15", "goal-not-reached")
    assert "IsOpen(box)" in issue.message


@pytest.fixture(scope="module")
def waiter() -> tuple[Record, ...]:
    """Three solved RoboWaiter records with costs: Make_Coffee (5), On_VacuumCup (52), On_Water (57)."""
    return tuple(load_dataset("fewshot_robowaiter_100")[:3])


def _codes(records: list[Record], optimal_cost: OptimalCost | None = None) -> list[tuple[str, Severity, str]]:
    report = validate_records(records, load_scenario("robowaiter").task, "test", optimal_cost=optimal_cost)
    return [(issue.record_id, issue.severity, issue.code) for issue in report.issues]


def test_validation_of_good_records(waiter: tuple[Record, ...]) -> None:
    report = validate_records(iter(waiter), load_scenario("robowaiter").task, "mine")
    assert (report.dataset, report.scenario, report.records, report.issues) == ("mine", "robowaiter", 3, ())
    assert report.valid
    assert report.summary() == "mine vs robowaiter: 3 records, 0 invalid, 0 with warnings"


def test_validation_collects_errors_without_raising(waiter: tuple[Record, ...]) -> None:
    coffee, cup, water = waiter
    replace = dataclasses.replace
    records = [
        replace(coffee, id="a", optimal_actions=("Make_Tea",)),
        replace(coffee, id="b", optimal_actions=("Fly",)),
        replace(coffee, id="c", goal="Exists_Unicorn"),
        replace(coffee, id="d", goal="Flying_Coffee"),
        replace(coffee, id="e", goal="IsOn_"),
        replace(coffee, id="e2", goal="Exists_Table1"),
        replace(coffee, id="f", cost=6),
        replace(coffee, id="g", vital_predicates=("Make", "Fly")),
        replace(coffee, id="h", vital_objects=("Coffee", "Unicorn")),
        replace(water, id="i", optimal_actions=water.optimal_actions[:-2] + water.optimal_actions[-1:], cost=None),
        replace(water, id="j", optimal_actions=water.optimal_actions[:-1], cost=None),
        replace(cup, id="k", environment="2"),
    ]
    assert _codes(records) == [
        ("a", Severity.ERROR, "unknown-action"),
        ("b", Severity.ERROR, "unknown-action"),
        ("c", Severity.ERROR, "unknown-literal"),
        ("d", Severity.ERROR, "unknown-literal"),
        ("e", Severity.ERROR, "unknown-literal"),
        ("e2", Severity.ERROR, "unreachable-literal"),
        ("f", Severity.ERROR, "cost-mismatch"),
        ("g", Severity.ERROR, "unknown-predicate"),
        ("h", Severity.ERROR, "unknown-object"),
        ("i", Severity.ERROR, "not-applicable"),
        ("j", Severity.ERROR, "goal-not-reached"),
        ("k", Severity.WARNING, "unknown-environment"),
    ]
    report = validate_records(records, load_scenario("robowaiter").task)
    assert report.invalid_ids == ("a", "b", "c", "d", "e", "e2", "f", "g", "h", "i", "j")
    assert report.warning_ids == ("k",)
    assert not report.valid
    messages = {issue.record_id: issue.message for issue in report.issues}
    assert "Make(Tea)" in messages["a"]
    assert "Unicorn" in messages["c"]
    assert "Exists(Table1)" in messages["e2"]
    assert "declared cost 6" in messages["f"]
    assert "'Fly'" in messages["g"]
    assert "action 4 PutDown(Water,Table1)" in messages["i"]
    assert "On(Water,Table1)" in messages["j"]
    data = report.to_dict()
    assert data["invalid_ids"] == list(report.invalid_ids)
    assert data["issues"][0] == {
        "record_id": "a",
        "severity": "error",
        "code": "unknown-action",
        "message": messages["a"],
    }


def test_goal_true_in_s0_is_a_warning(waiter: tuple[Record, ...]) -> None:
    task = load_scenario("robowaiter").task
    holds = task.atoms[min(task.initial_state)]
    record = Record("z", holds.underscored, (), (), ())
    assert _codes([record]) == [("z", Severity.WARNING, "goal-true-in-s0")]


def test_not_optimal_hook(waiter: tuple[Record, ...]) -> None:
    asked: list[str] = []

    def optimum(record: Record) -> int | None:
        asked.append(record.id)
        return {"1": 5, "2": 40}.get(record.id)

    assert _codes(list(waiter), optimal_cost=optimum) == [("2", Severity.WARNING, "not-optimal")]
    assert asked == ["1", "2", "3"]
    broken = dataclasses.replace(waiter[0], optimal_actions=())
    assert Counter(c for _, _, c in _codes([broken], optimal_cost=optimum)) == {
        "goal-not-reached": 1,
        "cost-mismatch": 1,
    }


# ------------------------------------------------------------------ costs on the command line
def test_costs_with_leading_zeros_are_read() -> None:
    text = TWO_RECORDS.replace("cost: 12", "cost: " + "0" * 30 + "12")
    assert read_text(text)[0].cost == 12


@pytest.mark.parametrize(
    ("name", "cost_line", "fragment"),
    [
        ("big.txt", "cost: " + "9" * 5000, "big.txt:8: record 1: cost has 5000 digits"),
        ("arabic.txt", "cost: \u0663", "arabic.txt:8: record 1: cost must be a non-negative integer in ASCII"),
        ("under.txt", "cost: 1_0", "under.txt:8: record 1: cost must be a non-negative integer in ASCII"),
    ],
)
def test_bad_costs_are_one_line_input_errors_on_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, cost_line: str, fragment: str
) -> None:
    from hbtp.cli import EXIT_INPUT, main

    path = tmp_path / name
    path.write_text(TWO_RECORDS.replace("cost: 12", cost_line), encoding="utf-8")
    assert main(["dataset", "validate", str(path), "-s", "robothow"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert fragment in err
    assert "internal error" not in err
    # As --hints, a file that is not a valid dataset is read as a raw LLM reply: no crash either.
    code = main(["plan", "-s", "robothow", "-g", "IsIn_milk_fridge & IsClose_fridge", "--hints", str(path)])
    assert code in (0, 1)
    assert "internal error" not in capsys.readouterr().err


def test_a_5000_digit_jsonl_cost_is_a_one_line_input_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from hbtp.cli import EXIT_INPUT, main

    path = tmp_path / "big.jsonl"
    line = write_jsonl(read_text(TWO_RECORDS)[:1]).replace('"cost": 12', '"cost": ' + "9" * 5000)
    path.write_text(line, encoding="utf-8")
    assert main(["dataset", "validate", str(path), "-s", "robothow"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err.strip() == f"hbtp: error: {path}:1: invalid JSON: a number with too many digits"
    code = main(["plan", "-s", "robothow", "-g", "IsIn_milk_fridge & IsClose_fridge", "--hints", str(path)])
    assert code == EXIT_INPUT
    assert "internal error" not in capsys.readouterr().err
