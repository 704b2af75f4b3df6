"""The layering holds: configuration is read at the edges only, and the maths never imports it."""

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "loadarm"
#: Modules that may read configuration: the edges (command line, report, docs, compiler, scenario loading,
#: campaigns that redraw scenario and installation parameters per run, the berth file, the operability study that
#: reads the installation, berth and metocean files and sends the compiled objects to its workers).
EDGES = {"cli.py", "report.py", "docsgen.py", "compiler.py", "config.py", "guidance/scenario.py", "guidance/campaign.py",
         "berth.py", "__init__.py", "studies/operability.py"}
MATHS = sorted(p for p in SRC.rglob("*.py") if str(p.relative_to(SRC)) not in EDGES
               and not str(p.relative_to(SRC)).startswith("examples"))


def _runtime_imports(path: Path) -> set[str]:
    """Modules imported at run time (imports under ``if TYPE_CHECKING:`` are for annotations only)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            skip.update(id(n) for n in ast.walk(node))
    out = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom):
            out.add("." * node.level + (node.module or ""))
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize("path", MATHS, ids=[str(p.relative_to(SRC)) for p in MATHS])
def test_maths_does_not_import_config_or_the_compiler(path):
    bad = {m for m in _runtime_imports(path) if m.lstrip(".").split(".")[0] in ("config", "compiler")
           or m in ("loadarm.config", "loadarm.compiler")}
    assert not bad, f"{path.relative_to(SRC)} imports {sorted(bad)}: take an ArmModel instead"


def test_the_installation_becomes_maths_objects_in_one_place():
    """Only the compiler builds the arm from an installation; sizing, which runs from the datasheet before
    an arm exists (`loadarm size`), builds the sized and the optional configured arm for its corner table."""
    hits = sorted(str(p.relative_to(SRC)) for p in SRC.rglob("*.py") if "Arm(inst." in p.read_text(encoding="utf-8"))
    assert hits == ["compiler.py", "sizing.py"]
    assert not [p for p in SRC.rglob("*.py") if "_from_installation(" in p.read_text(encoding="utf-8")]


def test_planning_never_imports_the_simulator():
    """Found: compiling the model imported numba (the closed loop), adding ~0.2 s to `loadarm plan`'s start."""
    import subprocess
    import sys

    code = ("import sys; from loadarm.cli import main; main(['plan', '-c', 'examples/paper.toml', '--json']); "
            "sys.stderr.write(','.join(m for m in ('numba', 'scipy', 'matplotlib', 'mujoco', 'toppra') "
            "if m in sys.modules))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=SRC.parents[1])
    assert r.returncode == 0 and r.stderr.strip() == "", r.stderr
