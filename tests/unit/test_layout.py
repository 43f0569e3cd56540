"""The package layout's import rules (docs/architecture in README, docs/studies.md):

- the shared contracts (`handover_model`) import neither the services nor the simulator;
- services other than the bridge and the simulated Kinect never import the simulator
  (`robot_sim`); the offline studies (`services/studies`) may;
- no service imports a study;
- no module over 400 lines, no function over 80.
"""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: Services that run the simulator in-process: the bridge's sim backend, the simulated Kinect.
SIMULATOR_USERS = {"bridge", "sim_kinect", "studies"}


def imported_modules(path: Path) -> set[str]:
    """Every module an `import` or `from ... import` in `path` names (at any depth)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def offenders(paths: list[Path], package: str) -> list[str]:
    """`path: [modules]` for each file that imports `package` or one of its modules."""
    found = []
    for path in paths:
        bad = sorted(n for n in imported_modules(path) if n == package or n.startswith(f"{package}."))
        if bad:
            found.append(f"{path.relative_to(REPO)}: {bad}")
    return found


def service_files(exclude: set[str]) -> list[Path]:
    return [p for p in sorted((REPO / "services").rglob("*.py"))
            if p.relative_to(REPO / "services").parts[0] not in exclude]


def test_the_finder_sees_imports_at_every_depth(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("def f():\n    from robot_sim.kinect import receiver\n    import robot_sim.contact\n")
    assert imported_modules(probe) >= {"robot_sim.kinect", "robot_sim.kinect.receiver", "robot_sim.contact"}


def test_services_other_than_bridge_and_sim_kinect_never_import_the_simulator():
    assert offenders(service_files(SIMULATOR_USERS), "robot_sim") == []


def test_no_service_imports_the_studies():
    """Studies import services, never the reverse: a service starts without matplotlib or the
    benchmark's code, and a study can change without touching a running stack."""
    assert offenders(service_files({"studies"}), "services.studies") == []


def test_the_shared_contracts_import_neither_services_nor_simulator():
    contracts = sorted((REPO / "handover_model").rglob("*.py"))
    assert contracts, "handover_model/ has no modules"
    assert offenders(contracts, "robot_sim") + offenders(contracts, "services") == []


LIBRARY_PACKAGES = ("bus_schema", "handover_model", "services", "robot_sim")
MAX_FILE_LINES = 400
MAX_FUNCTION_LINES = 80


def library_files() -> list[Path]:
    return [p for package in LIBRARY_PACKAGES for p in sorted((REPO / package).rglob("*.py"))]


def test_no_module_is_over_400_lines_and_no_function_over_80():
    """Small modules of one job (docs/testing.md): a module over 400 lines or a function over
    80 is split by responsibility, not given an exception."""
    long_files, long_functions = [], []
    for path in library_files():
        text = path.read_text()
        if text.count("\n") > MAX_FILE_LINES:
            long_files.append(f"{path.relative_to(REPO)}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long_functions.append(f"{path.relative_to(REPO)}:{node.lineno} {node.name}: {lines} lines")
    assert len(library_files()) > 200
    assert long_files == [] and long_functions == []
