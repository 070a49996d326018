"""The house rules of issue 14, checked on the source tree (AST, no imports).

- no function in geometry/, pipelines/, worker/, service/ or cli/ longer than 120 lines;
- no public function in geometry/, pipelines/ or worker/ with more than 10 parameters
  (options objects instead);
- no module of those packages, of conformorph_client/ or of tests/ over 600 lines;
- no import cycle between the project's modules (module-level and function-level
  imports alike; a module importing its own parent package is not counted).
"""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CODE = ("geometry", "pipelines", "worker", "service", "cli")
PARAM_CHECKED = ("geometry", "pipelines", "worker")
MAX_FUNCTION_LINES = 120
MAX_PARAMETERS = 10
MAX_MODULE_LINES = 600


def _modules(*folders: str) -> list[Path]:
    return [p for d in folders for p in sorted((ROOT / d).rglob("*.py"))]


def _functions(path: Path) -> list[ast.FunctionDef | ast.AsyncFunctionDef]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)]


def _parameters(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    return len(names) - (1 if names[:1] in (["self"], ["cls"]) else 0)


def test_no_function_over_120_lines() -> None:
    long = [
        f"{p.relative_to(ROOT)}:{fn.name} ({fn.end_lineno - fn.lineno + 1} lines)"
        for p in _modules(*CODE)
        for fn in _functions(p)
        if fn.end_lineno is not None and fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert long == []


def test_no_public_function_over_10_parameters() -> None:
    many = [
        f"{p.relative_to(ROOT)}:{fn.name} ({_parameters(fn)} parameters)"
        for p in _modules(*PARAM_CHECKED)
        for fn in _functions(p)
        if not fn.name.startswith("_") and _parameters(fn) > MAX_PARAMETERS
    ]
    assert many == []


def test_no_module_over_600_lines() -> None:
    big = [
        f"{p.relative_to(ROOT)} ({n} lines)"
        for p in _modules(*CODE, "conformorph_client", "tests")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    ]
    assert big == []


def _installed_name(name: str) -> str:
    """``name`` as installed: the project's folders are ``conformorph.geometry`` and so on."""
    return f"conformorph.{name}" if name.split(".")[0] in CODE else name


def _folder(module: str) -> str:
    """The repository folder of an installed module name."""
    return module.removeprefix("conformorph.").split(".")[0]


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return _installed_name(".".join(parts))


def _import_graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in _modules(*CODE, "conformorph_client")}
    edges: dict[str, set[str]] = defaultdict(set)
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [_installed_name(a.name) for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = _installed_name(node.module or "")
                if node.level:
                    parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                    base = ".".join([*parts, base] if base else parts)
                targets = [base, *(f"{base}.{a.name}" for a in node.names)]
            for t in targets:
                if t in files and t != name and not name.startswith(t + "."):
                    edges[name].add(t)
    return edges


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[list[str]] = []
    counter = 0
    nodes = set(edges) | {w for ws in edges.values() for w in ws}
    for root in sorted(nodes):
        if root in index:
            continue
        work = [(root, iter(sorted(edges.get(root, ()))))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            v, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    advanced = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def test_cycle_finder_finds_a_known_cycle() -> None:
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(edges) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


@pytest.mark.parametrize("folder", CODE)
def test_no_import_cycles(folder: str) -> None:
    cycles = [c for c in _cycles(_import_graph()) if any(_folder(m) == folder for m in c)]
    assert cycles == []


def test_import_graph_knows_old_and_installed_names() -> None:
    """Imports by either name are edges between the installed names."""
    edges = _import_graph()
    assert "conformorph.worker.names" in edges["conformorph.worker.dispatch"]
    assert "conformorph.geometry" in edges["conformorph.pipelines.conformal.disk_map"]
    assert _folder("conformorph.geometry.threads") == "geometry"
    assert _installed_name("conformorph_client.models") == "conformorph_client.models"
