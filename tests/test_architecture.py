"""The house as docs/architecture.md declares it: layers in one table, data flowing one way.

The test reads the layer table and the heavy-library list from ``docs/architecture.md`` (the one declaration)
and fails on: an import circle, an upward import, a function-level import of a loadarm module, a lazy import of
an undeclared library, a module no row places, a function above complexity 15, and a second declaration of an
alarm tag, an action or a face's words.
"""

from __future__ import annotations

import ast
import re
import sys
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "loadarm"
DOC = ROOT / "docs" / "architecture.md"


def _module(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


SOURCES = sorted(p for p in SRC.rglob("*.py") if "__pycache__" not in p.parts and "examples" not in p.parts)
MODULES = {_module(p): p for p in SOURCES}


@cache
def layers() -> dict[str, int]:
    """Module prefix -> rank, from the table between the layer markers of docs/architecture.md."""
    text = DOC.read_text(encoding="utf-8")
    table = text.split("<!-- layers: begin -->")[1].split("<!-- layers: end -->")[0]
    out = {}
    for row in table.splitlines():
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].isdigit():
            continue
        for name in re.findall(r"`([\w/]+)`", cells[2]):
            out["loadarm." + name.rstrip("/").replace("/", ".")] = int(cells[0])
    return out


@cache
def heavy() -> frozenset[str]:
    text = DOC.read_text(encoding="utf-8").split("<!-- heavy: -->")[1].split("<!-- :heavy -->")[0]
    return frozenset(re.findall(r"`(\w+)`", text))


def rank(module: str) -> int | None:
    if module == "loadarm":
        return 0
    table = layers()
    parts = module.split(".")
    for i in range(len(parts), 1, -1):
        if ".".join(parts[:i]) in table:
            return table[".".join(parts[:i])]
    return None


def _absolute(node: ast.ImportFrom, module: str, is_pkg: bool) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if is_pkg else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _targets(node: ast.AST, module: str, is_pkg: bool) -> list[str]:
    """The loadarm modules an import statement loads (a name imported from a package may be a module)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.split(".")[0] == "loadarm"]
    target = _absolute(node, module, is_pkg)
    if target.split(".")[0] != "loadarm":
        return []
    return [f"{target}.{a.name}" if f"{target}.{a.name}" in MODULES else target for a in node.names]


@cache
def imports() -> dict[str, list[tuple[str, int, str]]]:
    """module -> [(imported loadarm module, line, where)] with where in {"top", "typing", "function"}."""
    out = {}
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        where = {}
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
                for sub in ast.walk(node):
                    where[id(sub)] = "function"
            elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                for sub in ast.walk(node):
                    where.setdefault(id(sub), "typing")
        found = []
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                for t in _targets(node, module, path.name == "__init__.py"):
                    found.append((t, node.lineno, where.get(id(node), "top")))
        out[module] = found
    return out


def lazy_libraries() -> list[tuple[str, int, str]]:
    out = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for node in ast.walk(fn):
                if isinstance(node, ast.Import):
                    names = [a.name for a in node.names]
                elif isinstance(node, ast.ImportFrom) and not node.level:
                    names = [node.module or ""]
                else:
                    continue
                for n in names:
                    top = n.split(".")[0]
                    if top != "loadarm" and top not in sys.stdlib_module_names:
                        out.append((module, node.lineno, top))
    return out


def test_every_module_has_a_layer():
    missing = sorted(m for m in MODULES if rank(m) is None)
    assert not missing, f"no row of docs/architecture.md's layer table places {missing}"


def test_no_function_imports_a_loadarm_module():
    bad = [f"{m}:{line} imports {t}" for m, found in imports().items() for t, line, w in found if w == "function"]
    assert not bad, "a function-level import hides an arrow (and may close a circle):\n" + "\n".join(bad)


def test_lazy_imports_are_declared_heavy_libraries():
    bad = [f"{m}:{line} imports {lib}" for m, line, lib in lazy_libraries() if lib not in heavy()]
    assert not bad, "only the declared heavy libraries are imported in functions:\n" + "\n".join(bad)


def test_no_upward_import():
    bad = []
    for module, found in imports().items():
        for target, line, _ in found:
            if rank(target) is not None and rank(module) is not None and rank(target) > rank(module):
                bad.append(f"{module}:{line} (rank {rank(module)}) imports {target} (rank {rank(target)})")
    assert not bad, "data flows one way; an import runs back up:\n" + "\n".join(bad)


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan), or a module importing itself."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v, counter=[0]):  # noqa: B006 (the counter is this walk's)
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_circle():
    """No circle, not even through imports for annotations only (``if TYPE_CHECKING:``): a circle there is two
    modules that each need the other's types, the same knot the runtime hides."""
    graph = {m: {t for t, _, _ in found if t in MODULES and t != m} for m, found in imports().items()}
    assert not _cycles(graph), f"import circles: {_cycles(graph)}"


def test_the_checker_sees_a_circle_and_an_upward_import():
    """The checks can fail: a planted circle and a planted upward arrow are found."""
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert rank("loadarm.arm.faces") < rank("loadarm.guidance.controller") < rank("loadarm.cli")
    assert rank("loadarm.vocab") == 0 and rank("loadarm.nonexistent") is None


def test_no_function_above_complexity_15():
    """McCabe complexity as ruff counts it (C901), over the whole package."""
    import subprocess

    r = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", "--isolated", "--select", "C901",
                        "--config", "lint.mccabe.max-complexity = 15", "--output-format", "concise", str(SRC)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_arm_model_is_typed_field_by_field():
    """Found (issue 26): ``ArmModel`` had 12 fields typed ``Any``, made from config field names. Now every field
    names its type, and each parameter record carries its keys' declared types (a key declared once, in the
    configuration)."""
    import dataclasses
    import typing

    from loadarm.arm.model import ArmModel, ParamRecord
    from loadarm.params.compiler import compile_model
    from loadarm.params.config import paper_installation

    hints = typing.get_type_hints(ArmModel)
    assert hints and typing.Any not in hints.values()
    model = compile_model(paper_installation())
    records = [getattr(model, f.name) for f in dataclasses.fields(model)
               if isinstance(getattr(model, f.name), ParamRecord)]
    assert len(records) >= 12
    for rec in records:
        types_ = {f.name: f.type for f in dataclasses.fields(rec)}
        assert types_ and typing.Any not in types_.values(), type(rec).__name__


def _annotation_nodes(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        anns = []
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            anns = [a.annotation for a in node.args.args + node.args.kwonlyargs + node.args.posonlyargs] + \
                   [node.returns, getattr(node.args.vararg, "annotation", None),
                    getattr(node.args.kwarg, "annotation", None)]
        elif isinstance(node, ast.AnnAssign):
            anns = [node.annotation]
        for a in anns:
            if a is not None:
                out.update(id(n) for n in ast.walk(a))
    return out


def test_a_name_imported_for_annotations_only_is_not_used_at_run_time():
    """Found (issue 26): the operability figure called ``Figure(...)`` whose import had moved under
    ``if TYPE_CHECKING:`` (a NameError only when the figure was drawn; pyflakes counts the name as defined).
    A name imported for annotations only is used in annotations only, unless a function imports it itself."""
    bad = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        typing_only = set()
        for node in tree.body:
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                for sub in ast.walk(node):
                    if isinstance(sub, (ast.Import, ast.ImportFrom)):
                        typing_only.update((a.asname or a.name).split(".")[0] for a in sub.names)
        if not typing_only:
            continue
        skip = _annotation_nodes(tree)
        for fn in [tree] + [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]:
            local = {(a.asname or a.name).split(".")[0] for n in ast.walk(fn) if fn is not tree
                     and isinstance(n, (ast.Import, ast.ImportFrom)) for a in n.names}
            body = fn.body if fn is tree else [fn]
            for stmt in body:
                if fn is tree and isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    continue                  # functions are walked on their own (their local imports count)
                for n in ast.walk(stmt):
                    if (isinstance(n, ast.Name) and isinstance(n.ctx, ast.Load) and n.id in typing_only
                            and n.id not in local and id(n) not in skip):
                        bad.append(f"{module}:{n.lineno} uses {n.id}")
    assert not sorted(set(bad)), sorted(set(bad))


def test_every_dotted_reference_in_the_docs_and_docstrings_resolves():
    """Docs cannot drift: every ``loadarm.x.y`` named in docs/, README.md, the package's docstrings and
    templates names a module or an attribute that exists (found, issue 26: references to the modules of the
    old layout would have stayed behind the move)."""
    import importlib

    texts = [p for p in (ROOT / "docs").glob("*.md")] + [ROOT / "README.md"] + \
        [p for p in SRC.rglob("*") if p.suffix in (".py", ".j2") and "__pycache__" not in p.parts]
    bad = set()
    for path in texts:
        for ref in re.findall(r"(?<![\w/.])loadarm(?:\.[A-Za-z_]\w*)+", path.read_text(encoding="utf-8")):
            parts = ref.split(".")
            for i in range(len(parts), 0, -1):
                try:
                    obj, rest = importlib.import_module(".".join(parts[:i])), parts[i:]
                    break
                except ImportError:
                    continue
            for name in rest:
                if not hasattr(obj, name):
                    bad.add(f"{path.relative_to(ROOT)}: {ref}")
                    break
                obj = getattr(obj, name)
    assert not bad, sorted(bad)


def test_planning_never_imports_the_simulator():
    """``loadarm plan`` loads only its command's module (``cli.COMMAND_MODULES``): no numba, SciPy, matplotlib,
    MuJoCo or toppra. Found (before issue 26): compiling the model imported numba, adding ~0.2 s to the start."""
    import subprocess

    code = ("import sys; from loadarm.cli import main; main(['plan', '-c', 'examples/paper.toml', '--json']); "
            "sys.stderr.write(','.join(m for m in ('numba', 'scipy', 'matplotlib', 'mujoco', 'toppra') "
            "if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 0 and r.stderr.strip() == "", r.stderr


def test_every_command_names_its_module_and_the_module_defines_it():
    """The lazy table and the command modules agree: each command in ``COMMAND_MODULES`` is defined by its
    module's ``app``, and no module defines a command the table does not list."""
    from typer.main import get_group

    from loadarm.cli import COMMAND_MODULES, GROUPS

    import importlib

    defined = {}
    for module in set(COMMAND_MODULES.values()):
        group = get_group(importlib.import_module(module).app)
        names = {group.name} if group.name in GROUPS else set(group.commands)
        defined.update({n: module for n in names})
    assert defined == COMMAND_MODULES
