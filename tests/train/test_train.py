"""Teaching the local model (hbtp train): the examples are the planner's optimal labels and never
an evaluation set's goals; adapters are chosen, checked and refused as the docs say; and (in CI's
second stage, with the train extra) a tiny training run writes an adapter that xllamacpp applies
and whose answers agree with the merged torch model."""

from __future__ import annotations

import importlib.util
import json
import logging
import struct
import warnings
from pathlib import Path

import pytest

from hbtp.domains import Scenario, load_scenario
from hbtp.llm.backend import PromptStyle
from hbtp.llm.backends.adapters import (
    KEY_BASE,
    KEY_FORMAT,
    KEY_WORLD,
    PROMPT_FORMAT,
    AdapterChoice,
    AdapterMode,
    choose_adapter,
    filled_of,
    read_metadata,
    spelling_of,
    unfit,
    world_key,
)
from hbtp.llm.prompt import PromptOptions, build_request, taught_prompt
from hbtp.llm.spelling import Spelling, read_plan
from hbtp.planning import plan
from hbtp.train.example_set import make_examples
from hbtp.train.examples import (
    ExampleKind,
    LeakError,
    check_disjoint,
    evaluation_goals,
    goal_key,
    held_goals,
    hints_example,
)

HAVE_TRAIN = all(importlib.util.find_spec(name) for name in ("torch", "transformers", "peft", "gguf"))
HAVE_XLLAMACPP = importlib.util.find_spec("xllamacpp") is not None


# ----------------------------------------------------------------------------- the examples
@pytest.fixture(scope="module")
def robowaiter_examples(robowaiter: Scenario) -> object:
    return make_examples(robowaiter, 40, seed=3, held_out=0.25)


def test_examples_are_optimal_labels_in_the_short_prompt(robowaiter: Scenario, robowaiter_examples: object) -> None:
    examples = robowaiter_examples
    every = [e for e in (*examples.train, *examples.held_out) if e.kind is ExampleKind.HINTS]  # type: ignore[attr-defined]
    assert len(every) >= 20
    held = [e for e in examples.held_out if e.kind is ExampleKind.HINTS]  # type: ignore[attr-defined]
    assert len(held) == round(len(every) * 0.25)
    task = robowaiter.task
    for example in every:
        assert example.prompt == taught_prompt(example.goal)
        assert example.reply.startswith(" ")
        assert example.reply.endswith("\n\n")
        # the label's plan reaches the goal, and no plan is cheaper (an independent optimal search)
        line = example.reply.split("\n")[0]
        actions = [task.action(name) for name in read_plan(line).strip().split(", ") if name]
        assert line == Spelling.SPACED.plan(action.signature for action in actions)  # the tokens it saves
        state = task.initial_state
        for action in actions:
            assert action.applicable(state)
            state = action.progress(state)
        goal = task.resolve_goal(example.goal)
        assert goal.holds(state)
        best = plan(task, goal, "obtea", heuristic="none", mutexes=robowaiter.mutexes.proved_only())
        assert sum(a.cost for a in actions) == best.cost


def test_held_back_goals_are_in_no_training_example_of_either_kind(robowaiter_examples: object) -> None:
    train, held = robowaiter_examples.train, robowaiter_examples.held_out  # type: ignore[attr-defined]
    assert {e.kind for e in train} == {ExampleKind.HINTS, ExampleKind.GOAL}
    held_labels = {goal_key(e.goal) for e in held if e.kind is ExampleKind.HINTS}
    trained = {goal_key(part) for e in train for part in e.goal.split(" | ")}
    assert held_labels
    assert not held_labels & trained


def test_examples_are_deterministic_for_a_seed(robowaiter: Scenario) -> None:
    first = make_examples(robowaiter, 20, seed=5)
    assert make_examples(robowaiter, 20, seed=5) == first
    assert make_examples(robowaiter, 20, seed=6) != first


@pytest.mark.parametrize("name", ["robowaiter", "virtualhome", "robothow-small", "robothow"])
def test_no_evaluation_goal_is_trained_on(name: str, request: pytest.FixtureRequest) -> None:
    scenario = request.getfixturevalue(name.replace("-", "_"))
    held = evaluation_goals(name)
    assert len(held) >= 30  # the distinct goals of the Table II set, and of the instruction dataset
    examples = make_examples(scenario, 30, seed=1)
    assert not {goal_key(e.goal) for e in (*examples.train, *examples.held_out)} & held


def test_a_leak_is_refused(robowaiter: Scenario, robowaiter_examples: object) -> None:
    from hbtp.datasets import load_dataset

    leaked = load_dataset("table2_robowaiter_50")[0]
    examples = [*robowaiter_examples.train, hints_example(leaked, robowaiter.task)[0]]  # type: ignore[attr-defined]
    with pytest.raises(LeakError, match=r"1 training goal\(s\) belong to an evaluation set of 'robowaiter'"):
        check_disjoint(examples, held_goals(robowaiter), robowaiter.name)


def test_a_pddl_problems_own_goal_is_held_back(tmp_path: Path) -> None:
    from hbtp.domains import load_pddl_scenario

    folder = Path(__file__).resolve().parents[3] / "shared" / "benchmarks" / "ipc" / "gripper"
    if not folder.is_dir():
        pytest.skip("no IPC benchmarks beside the repository")
    scenario = load_pddl_scenario(folder / "domain.pddl", folder / "prob01.pddl")
    assert goal_key(scenario.problem_goal()) in held_goals(scenario)


def test_a_world_too_small_to_sample_is_refused(tmp_path: Path) -> None:
    from hbtp.domains import load_pddl_scenario
    from hbtp.errors import InputError

    (tmp_path / "d.pddl").write_text(
        "(define (domain d) (:predicates (p) (q)) (:action a :parameters () :precondition (q) :effect (p)))"
    )
    (tmp_path / "p.pddl").write_text("(define (problem p) (:domain d) (:init (p)) (:goal (p)))")
    scenario = load_pddl_scenario(tmp_path / "d.pddl", tmp_path / "p.pddl")
    with pytest.raises(InputError, match="too small"):
        make_examples(scenario, 20)


# ----------------------------------------------------------------------------- choosing adapters
def _gguf(path: Path, fields: dict[str, str | float | int], tensors: dict[str, tuple[int, int]] | None = None) -> Path:
    """A GGUF file with ``fields`` as metadata and F32 ``tensors`` of the given ggml shapes (zeros)."""
    tensors = tensors or {}
    data = b"GGUF" + struct.pack("<IQQ", 3, len(tensors), len(fields))
    for key, value in fields.items():
        data += struct.pack("<Q", len(key)) + key.encode()
        if isinstance(value, float):
            data += struct.pack("<I", 6) + struct.pack("<f", value)
        elif isinstance(value, int):
            data += struct.pack("<I", 4) + struct.pack("<I", value)  # uint32
        else:
            data += struct.pack("<I", 8) + struct.pack("<Q", len(value)) + value.encode()
    offset = 0
    for name, shape in tensors.items():
        data += struct.pack("<Q", len(name)) + name.encode() + struct.pack("<I", 2) + struct.pack("<QQ", *shape)
        data += struct.pack("<IQ", 0, offset)  # F32, at this offset of the data
        offset += -(-shape[0] * shape[1] * 4 // 32) * 32
    data += b"\0" * (-len(data) % 32) + b"\0" * offset
    path.write_bytes(data)
    return path


ADAPTER = {"general.architecture": "gemma3", "general.type": "adapter", "adapter.type": "lora"}


def test_too_little_memory_or_disk_is_refused_before_any_work(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    from hbtp.cli import main
    from hbtp.train import run

    monkeypatch.setattr(run, "_available_memory_mb", lambda: 500.0)
    argv = ["train", "-s", "robowaiter", "-n", "10", "--work", str(tmp_path / "work"), "-o", str(tmp_path / "a.gguf")]
    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0
    assert "free memory" in error
    assert not (tmp_path / "work" / "examples.json").exists()  # refused before the examples
    monkeypatch.setattr(run, "_available_memory_mb", lambda: None)  # /proc/meminfo unreadable: not checked
    usage = shutil.disk_usage(tmp_path)
    monkeypatch.setattr(run.shutil, "disk_usage", lambda _folder: usage._replace(free=50_000_000))
    assert main(argv) == 2
    assert "free disk" in capsys.readouterr().err


def test_adapter_metadata_is_read_and_checked(tmp_path: Path) -> None:
    good = _gguf(tmp_path / "good.gguf", {**ADAPTER, "adapter.lora.alpha": 16.0, KEY_BASE: "abc", KEY_WORLD: "w1"})
    assert read_metadata(good)[KEY_WORLD] == "w1"
    assert unfit(good, world="w1", base_sha256="abc") is None
    assert "another world" in (unfit(good, world="w2", base_sha256="abc") or "")
    assert "another base model" in (unfit(good, world="w1", base_sha256="xyz") or "")
    model = _gguf(tmp_path / "model.gguf", {"general.architecture": "gemma3", "general.type": "model"})
    assert unfit(model, world=None, base_sha256=None) == "it is not a LoRA adapter"
    (tmp_path / "junk.gguf").write_bytes(b"GGUF\x03\x00")
    assert "cannot be read" in (unfit(tmp_path / "junk.gguf", world=None, base_sha256=None) or "")
    (tmp_path / "text.gguf").write_text("hello")
    assert "not a GGUF file" in (unfit(tmp_path / "text.gguf", world=None, base_sha256=None) or "")


def test_adapters_of_both_prompt_formats_fit_and_say_their_spelling(tmp_path: Path) -> None:
    """Format 2 adapters (plans spelled ``Walk_milk``) are still used; format 3 spells ``Walk milk``;
    an unknown format is refused."""
    for written, spelling in ((2, Spelling.UNDERSCORED), (3, Spelling.SPACED)):
        path = _gguf(tmp_path / f"f{written}.gguf", {**ADAPTER, KEY_FORMAT: written})
        assert unfit(path, world=None, base_sha256=None) is None
        assert spelling_of(path) is spelling
    assert PROMPT_FORMAT == 3  # what hbtp train teaches now
    unknown = _gguf(tmp_path / "f9.gguf", {**ADAPTER, KEY_FORMAT: 9})
    assert "prompt format 9" in (unfit(unknown, world=None, base_sha256=None) or "")


def test_an_unfit_adapter_is_left_out_with_one_warning(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    other = _gguf(tmp_path / "other.gguf", {**ADAPTER, KEY_WORLD: "another"})
    choice = AdapterChoice(AdapterMode.FILE, other)
    with caplog.at_level(logging.WARNING):
        assert choose_adapter(choice, scenario="robowaiter", world="mine", base_sha256=None) is None
    assert len(caplog.records) == 1
    assert "made for another world" in caplog.text
    assert choose_adapter(AdapterChoice.parse("none"), scenario="robowaiter", world="mine", base_sha256=None) is None
    assert AdapterChoice.parse("./none").path == Path("none")


def test_auto_takes_the_cached_adapter_of_a_pddl_world(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HBTP_CACHE_DIR", str(tmp_path / "cache"))
    domain, problem = tmp_path / "d.pddl", tmp_path / "p.pddl"
    domain.write_text("(define (domain d))")
    problem.write_text("(define (problem p))")
    key = world_key(domain, problem)
    folder = tmp_path / "cache" / "adapters"
    folder.mkdir(parents=True)
    cached = _gguf(folder / f"{key}.gguf", {**ADAPTER, KEY_WORLD: key})
    assert choose_adapter(AdapterChoice(), scenario="p", world=key, base_sha256=None) == cached
    assert choose_adapter(AdapterChoice(), scenario="p", world="other", base_sha256=None) is None


def test_a_world_grown_from_a_shipped_one_takes_its_shipped_adapter() -> None:
    from hbtp.domains.scale import scaled_scenario
    from hbtp.llm.backends.adapters import shipped_adapter, shipped_for_world
    from hbtp.llm.backends.registry import BackendOptions, _adapters_of

    shipped = shipped_adapter("robowaiter")
    assert shipped is not None
    grown = scaled_scenario("robowaiter", 1.5)
    assert grown.name != "robowaiter"  # no shipped adapter of its own name
    key = world_key(grown.domain_file, grown.problem_file)
    assert shipped_for_world(key) == shipped
    assert _adapters_of(grown, BackendOptions())[0] == shipped
    assert _adapters_of(grown, BackendOptions(adapter=AdapterChoice.parse("none"))) == (None, None)
    assert shipped_for_world("not a world") is None


def test_a_shipped_adapter_may_have_a_companion_that_reads_instructions() -> None:
    from hbtp.domains import load_scenario
    from hbtp.llm.backend import Request
    from hbtp.llm.backends.adapters import instruction_adapter, shipped_adapter
    from hbtp.llm.backends.registry import BackendOptions, _adapters_of

    robothow = load_scenario("robothow")
    adapter, reader = _adapters_of(robothow, BackendOptions())
    assert adapter == shipped_adapter("robothow")
    assert reader is not None
    assert reader.name == "robothow.instructions.gguf"
    key = world_key(robothow.domain_file, robothow.problem_file)
    assert unfit(reader, world=key, base_sha256=None) is None  # taught the same world
    assert instruction_adapter(AdapterChoice.parse(str(adapter)), adapter, world=key, base_sha256=None) is None
    assert _adapters_of(load_scenario("robowaiter"), BackendOptions())[1] is None  # none shipped there
    # each request switches to its adapter: the hints' for a plan, the companion's for an instruction
    pytest.importorskip("xllamacpp")
    from hbtp.llm.backends.local import LocalBackend

    both = LocalBackend(adapter=adapter, instruction_adapter=reader, threads=1)
    taught = Request((), "Goals: IsCut_pancake\nOptimal Actions:", taught=True)
    reading = Request((), "Instruction: cut the pancake\nGoals:", taught=True, instruction="cut the pancake")
    assert both._lora(taught) == [{"id": 0, "scale": 1.0}, {"id": 1, "scale": 0.0}]
    assert both._lora(reading) == [{"id": 0, "scale": 0.0}, {"id": 1, "scale": 1.0}]
    assert both._lora(Request((), "Goals: x")) == [{"id": 0, "scale": 0.0}, {"id": 1, "scale": 0.0}]
    assert LocalBackend(adapter=adapter, threads=1)._lora(reading) is None  # one adapter reads all
    assert LocalBackend(instruction_adapter=reader, threads=1).instruction_adapter is None  # no companion alone


@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")
def test_two_adapters_in_one_model_answer_as_each_alone() -> None:
    from hbtp.llm.backend import Request
    from hbtp.llm.backends.adapters import shipped_adapter
    from hbtp.llm.backends.local import LocalBackend

    adapter = shipped_adapter("robothow")
    assert adapter is not None
    reader = adapter.with_name("robothow.instructions.gguf")
    plan = Request((), "Goals: IsIn_milk_fridge & IsClose_fridge\nOptimal Actions:", max_tokens=24, taught=True)
    goal = Request((), "Instruction: put the milk in the fridge\nGoals:", max_tokens=12, taught=True, instruction="x")
    replies = {}
    for name, backend in {
        "both": LocalBackend(adapter=adapter, instruction_adapter=reader, threads=1),
        "plans": LocalBackend(adapter=adapter, threads=1),
        "reads": LocalBackend(adapter=reader, threads=1),
    }.items():
        with backend:
            replies[name] = (backend.complete(plan).text, backend.complete(goal).text)
    assert replies["both"] == (replies["plans"][0], replies["reads"][1])


@pytest.mark.skipif(not HAVE_XLLAMACPP, reason="xllamacpp is not installed (the local extra)")
def test_a_corrupt_adapter_falls_back_to_the_base_model(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    from hbtp.llm.backend import Request
    from hbtp.llm.backends.local import LocalBackend

    # Metadata that passes the checks, tensors that do not fit the model: llama.cpp refuses them.
    shapes = {"blk.0.attn_q.weight.lora_a": (7, 3), "blk.0.attn_q.weight.lora_b": (3, 5)}
    broken = _gguf(tmp_path / "broken.gguf", {**ADAPTER, "adapter.lora.alpha": 16.0}, shapes)
    backend = LocalBackend(adapter=broken, threads=1)
    with caplog.at_level(logging.WARNING):
        reply = backend.complete(Request((), "Goals: On_Coffee_Table1\nOptimal Actions:", max_tokens=4))
    backend.close()
    assert not backend.taught
    assert "refused the adapter" in caplog.text
    assert isinstance(reply.text, str)


# ----------------------------------------------------------------------------- a tiny training run
@pytest.mark.extras
@pytest.mark.skipif(not (HAVE_TRAIN and HAVE_XLLAMACPP), reason="needs the train and local extras")
def test_a_tiny_training_run_writes_an_adapter_xllamacpp_applies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from hbtp.cli import main

    out = tmp_path / "rw.gguf"
    argv = ["train", "-s", "robowaiter", "-n", "10", "--held-out", "0.2", "--epochs", "8", "--batch", "4",
            "--learning-rate", "0.003", "-o", str(out), "--work", str(tmp_path / "work"), "--json"]  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(argv) == 0, capsys.readouterr().err
    # nothing of the libraries' own business reaches the user (deprecated names, a config looked for)
    assert not [str(w.message) for w in caught if "/peft/" in w.filename or "/transformers/" in w.filename]
    outcome = json.loads(capsys.readouterr().out)
    assert outcome["last_loss"] < outcome["first_loss"]
    assert outcome["held_out"]["examples"] >= 1  # the held-back goals (about 20% of 10), judged
    fields = read_metadata(out)
    assert fields["general.type"] == "adapter"
    assert fields["hbtp.scenario"] == "robowaiter"
    assert unfit(out, world=fields[KEY_WORLD], base_sha256=fields[KEY_BASE] or None) is None
    assert fields[KEY_FORMAT] == PROMPT_FORMAT
    assert spelling_of(out) is Spelling.SPACED
    # llama.cpp answers in the spaced spelling the grammar allows; the backend gives it back in the
    # datasets' spelling, every name an action of the world
    world = load_scenario("robowaiter")
    from hbtp.llm.backends.local import LocalBackend

    with LocalBackend(adapter=out, threads=1) as backend:
        options = PromptOptions().for_backend(PromptStyle.COMPLETION, True, backend.spelling)
        reply = backend.complete(build_request(world.task, "On_Coffee_Table1", [], options))
    names = reply.text.strip().split(", ")
    assert names
    assert all(world.task.action(name) for name in names)
    assert " " not in reply.text.strip().replace(", ", "")
    # the same command again: every step is in the checkpoint, the same adapter comes out
    first = out.read_bytes()
    assert main([*argv[:-1]]) == 0
    assert out.read_bytes() == first


def _llama_reply(adapter: Path | None, prompt: str, tokens: int) -> list[tuple[int, float]]:
    """llama.cpp's greedy reply to ``prompt``: each token's id and log-probability."""
    from hbtp.llm.backends.local import default_model_path, import_xllamacpp, make_params, start_server

    xllamacpp = import_xllamacpp()
    params = make_params(xllamacpp, default_model_path(), threads=2, context=256)
    if adapter is not None:
        params.lora_adapters = [xllamacpp.CommonAdapterLoraInfo(str(adapter), 1.0)]
    server = start_server(xllamacpp, params, what="the model")
    body = {"prompt": prompt, "max_tokens": tokens, "temperature": 0, "n_probs": 1, "cache_prompt": False}
    result = server.handle_completions(body)
    del server
    return [(item["id"], item["logprob"]) for item in result["choices"][0]["logprobs"]["content"]]


@pytest.mark.extras
@pytest.mark.skipif(not (HAVE_TRAIN and HAVE_XLLAMACPP), reason="needs the train and local extras")
def test_llama_cpp_with_the_written_adapter_agrees_with_the_torch_model(tmp_path: Path) -> None:
    """The adapter file is the trained LoRA: llama.cpp with it gives its greedy reply's tokens the
    log-probabilities the torch model with the LoRA gives them (the quantized base model costs a
    little), and far from what the torch model without the LoRA gives them."""
    import torch
    from peft import set_peft_model_state_dict

    from hbtp.cli import main
    from hbtp.llm.backends.local import default_model_path
    from hbtp.train.lora import TrainSettings, load_model, with_lora

    out, work = tmp_path / "rw.gguf", tmp_path / "work"
    argv = ["train", "-s", "robowaiter", "-n", "12", "--held-out", "0.2", "--epochs", "4", "--batch", "4",
            "--learning-rate", "0.005", "-o", str(out), "--work", str(work), "--no-eval", "--abridge"]  # fmt: skip
    assert main(argv) == 0
    # abridged labels: the adapter says which predicates its plans leave to the check
    filled = filled_of(out)
    assert "MoveTo" in filled
    assert set(filled) <= set(load_scenario("robowaiter").task.action_predicates)
    held = json.loads((work / "examples.json").read_text())["held_out"]
    prompt = next(e["prompt"] for e in held if e["kind"] == "hints")
    reply = _llama_reply(out, prompt, 8)

    tokenizer, model = load_model(default_model_path(), 2)
    adapted = with_lora(model, TrainSettings())
    set_peft_model_state_dict(adapted, torch.load(work / "checkpoint.pt", weights_only=False)["adapter"])
    adapted.eval()
    ids = tokenizer(prompt).input_ids + [token for token, _ in reply]
    start = len(ids) - len(reply)

    def logprobs(net: object) -> list[float]:
        with torch.no_grad():
            logits = net(input_ids=torch.tensor([ids])).logits[0].float()  # type: ignore[operator]
        table = torch.log_softmax(logits, dim=-1)
        return [float(table[start + i - 1, token]) for i, (token, _) in enumerate(reply)]

    with_lora = logprobs(adapted)
    with adapted.disable_adapter():
        without = logprobs(adapted)
    llama = [value for _, value in reply]
    agree = max(abs(a - b) for a, b in zip(llama, with_lora, strict=True))
    apart = max(abs(a - b) for a, b in zip(llama, without, strict=True))
    assert agree <= 0.35, (llama, with_lora)
    assert apart >= 3 * agree, (llama, with_lora, without)
    assert apart >= 0.5, (llama, with_lora, without)
