"""The package layering of DESIGN.md: only ``report/`` imports matplotlib; the TE runtime needs no learner."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "drivelash"


def _imports(path: Path) -> set[str]:
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module.split(".")[0])
    return out


def test_only_report_imports_matplotlib():
    offenders = [
        str(p.relative_to(SRC))
        for p in SRC.rglob("*.py")
        if "matplotlib" in _imports(p) and p.relative_to(SRC).parts[0] != "report"
    ]
    assert offenders == []
    # negative control: the check sees the imports report/ does make
    assert any("matplotlib" in _imports(p) for p in (SRC / "report").rglob("*.py"))


def test_te_runtime_and_protocol_import_no_learner():
    code = (
        "import sys, drivelash.te.runtime, drivelash.te.protocol;"
        "print(sorted(m for m in ('torch', 'sklearn', 'optuna', 'matplotlib') if m in sys.modules))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip() == "[]"


def test_the_command_line_and_the_estimator_import_no_store_and_build_no_ufunc():
    """Every ``drivelash`` command imports the command table (``drivelash.cli``, which imports
    ``commands.track``) and most import the estimator: neither loads SQLAlchemy (≈ 0.4 s; only the
    wear commands need it — ``commands.track`` imported ``drivelash.wear.words`` at the top, and the
    ``drivelash.wear`` package imports its store) nor builds the physics ufuncs (≈ 1.2 s; session
    26). Negative control: importing the wear package loads SQLAlchemy, and its public ``ingest``
    is the function (an eager package import keeps it so, whatever imported the submodule first)."""
    code = (
        "import sys, drivelash.cli, drivelash.estimation.deadzone, drivelash.commands.estimate\n"
        "from drivelash.physics import backlash\n"
        "print(sorted(m for m in ('sqlalchemy', 'alembic') if m in sys.modules), 'chi1' in vars(backlash))\n"
        "import drivelash.wear.ingest, drivelash.wear as w\n"
        "print(w.Store.__name__, w.load_fleet.__name__, callable(w.ingest), 'sqlalchemy' in sys.modules)\n"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.splitlines() == ["[] False", "Store load_fleet True True"], r.stdout
