"""Domains: PDDL reading and writing, grounding, invariants and mutexes, the shipped scenarios."""

from hbtp.domains.builder import DomainBuilder
from hbtp.domains.grounding import ground
from hbtp.domains.mutex import Mutexes, MutexGroup, infer_mutexes
from hbtp.domains.pddl_reader import read_domain, read_domain_file, read_problem, read_problem_file
from hbtp.domains.pddl_writer import write_domain, write_grounded, write_problem
from hbtp.domains.scenarios import Scenario, load_pddl_scenario, load_scenario, scenario_names

__all__ = [
    "DomainBuilder",
    "MutexGroup",
    "Mutexes",
    "Scenario",
    "ground",
    "infer_mutexes",
    "load_pddl_scenario",
    "load_scenario",
    "read_domain",
    "read_domain_file",
    "read_problem",
    "read_problem_file",
    "scenario_names",
    "write_domain",
    "write_grounded",
    "write_problem",
]
