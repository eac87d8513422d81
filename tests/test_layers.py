"""The package's shape: layers that only import downwards, imports at the top of files, a
torch-free core. The layer contracts live in pyproject.toml (import-linter)."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

from conftest import ROOT

LINT = [sys.executable, "-c", "import sys; from importlinter.cli import lint_imports_command; "
                              "sys.exit(lint_imports_command())"]
LAZY_ALLOWED = {"mitnerf.train.backend_torch"}
"""Internal modules that may be imported inside a function: they import an optional heavy dependency."""


def test_the_layer_contracts_hold():
    r = subprocess.run(LINT, capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout[-2000:]
    assert "2 kept, 0 broken" in r.stdout


def test_an_upward_import_breaks_them(tmp_path):
    """The check can fail: ``from ..experiments import ...`` in mitnerf/train breaks the layers."""
    shutil.copytree(ROOT / "mitnerf", tmp_path / "mitnerf", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path)
    with open(tmp_path / "mitnerf" / "train" / "fit.py", "a") as f:
        f.write("\nfrom ..experiments import report  # noqa\n")
    r = subprocess.run(LINT, capture_output=True, text=True, cwd=tmp_path, env={"PYTHONPATH": str(tmp_path),
                                                                              "PATH": "/usr/bin:/bin"})
    assert r.returncode != 0 and "mitnerf.train is not allowed to import mitnerf.experiments" in r.stdout


def module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts).replace(".__init__", "")


def test_internal_imports_sit_at_the_top_of_files():
    late = []
    for path in sorted((ROOT / "mitnerf").rglob("*.py")):
        package = module_name(path).rsplit(".", 0 if path.name == "__init__.py" else 1)[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for sub in ast.walk(node):
                if isinstance(sub, ast.ImportFrom) and sub.level:
                    base = package.split(".")
                    target = ".".join(base[:len(base) - sub.level + 1] + ([sub.module] if sub.module else []))
                elif isinstance(sub, ast.ImportFrom):
                    target = sub.module or ""
                elif isinstance(sub, ast.Import):
                    target = sub.names[0].name
                else:
                    continue
                if target.startswith("mitnerf") and target not in LAZY_ALLOWED:
                    late.append(f"{path.relative_to(ROOT)}:{sub.lineno} imports {target} inside a function")
    assert not late, "\n".join(late)


def test_the_core_runs_without_torch(tmp_path):
    """Every command but the torch engine works where torch cannot be imported."""
    code = f"""
import sys
sys.modules["torch"] = None                       # any `import torch` now fails
from mitnerf.cli import main
assert main(["dataset", "--scene", "square", "--views", "6", "--val", "2", "--test", "2", "--image-size", "32",
             "--out", "{tmp_path / 'd'}"]) == 0
assert main(["fit", "--data", "{tmp_path / 'd'}", "--iters", "5", "--out", "{tmp_path / 'r'}"]) == 0
assert main(["recipes"]) == 0
assert main(["fit", "--data", "{tmp_path / 'd'}", "--iters", "5", "--backend", "torch"]) == 2
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "the torch backend needs PyTorch" in r.stderr
