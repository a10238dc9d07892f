"""The Python package is layered: no module imports, at load time or inside a function, a module
that imports it back (imports under ``TYPE_CHECKING`` do not run and are not counted); the
command line has one usage error class, whichever module runs as ``__main__``."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Set

import robot_stiffness

PACKAGE = Path(robot_stiffness.__file__).parent


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(path: Path, modules: Set[str]) -> Set[str]:
    """The package's modules that ``path`` imports, anywhere in it but under ``TYPE_CHECKING``."""
    found: Set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.ImportFrom):
            names: List[str] = []
            if node.level == 1:
                names = [node.module.split(".")[0]] if node.module else [a.name for a in node.names]
            elif node.level == 0 and node.module and node.module.startswith("robot_stiffness"):
                parts = node.module.split(".")
                names = [parts[1]] if len(parts) > 1 else [a.name for a in node.names]
            found.update(n for n in names if n in modules)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "robot_stiffness" and len(parts) > 1 and parts[1] in modules:
                    found.add(parts[1])
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(encoding="utf-8")))
    return found


def _cycles(graph: Dict[str, Set[str]]) -> List[List[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: Dict[str, int] = {}
    low: Dict[str, int] = {}
    stack: List[str] = []
    on_stack: Set[str] = set()
    out: List[List[str]] = []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            strong(v)
    return out


def test_the_cycle_finder_finds_a_planted_cycle(tmp_path):
    # The check below can fail: three modules importing in a ring, one of them lazily, and a
    # fourth importing the ring only under TYPE_CHECKING.
    (tmp_path / "a.py").write_text("from .b import x\n")
    (tmp_path / "b.py").write_text("def f():\n    from . import c\n")
    (tmp_path / "c.py").write_text("from robot_stiffness.a import y\n")
    (tmp_path / "d.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import y\n")
    modules = {"a", "b", "c", "d"}
    graph = {m: _imports(tmp_path / f"{m}.py", modules) for m in modules}
    assert graph["d"] == set()
    assert _cycles(graph) == [["a", "b", "c"]]


def test_no_module_of_the_package_imports_one_that_imports_it_back():
    modules = {p.stem for p in PACKAGE.glob("*.py")}
    graph = {m: _imports(PACKAGE / f"{m}.py", modules) - {m} for m in modules}
    assert _cycles(graph) == []


def test_a_usage_error_of_a_verb_module_is_one_line_under_python_m(tmp_path):
    # `predict` and `compensate` live in their own modules: their CliError is the one the main
    # loop reports, also when the CLI runs as __main__ (no second copy of the module).
    for verb in (["predict", "vjm"], ["compensate", "vjm"]):
        model = tmp_path / "model.json"
        poses = tmp_path / "poses.csv"
        model.write_text("{}")
        poses.write_text("q1\n0\n")
        run = subprocess.run(
            [sys.executable, "-m", "robot_stiffness.cli", *verb, str(model), str(poses), "--out",
             str(tmp_path / "out.csv"), "--payload", "abc"],
            capture_output=True, text=True, timeout=120,
        )
        assert run.returncode == 1, run.stderr
        assert run.stderr.strip().splitlines() == [
            "robot-stiffness: error: --payload 'abc': expected numbers, MASS or MASS,cx,cy,cz (kg, m)"
        ], run.stderr
        assert not (tmp_path / "out.csv").exists()
