"""The package's shape (issue: 0.2 layout): no module over 500 lines and no function over 100
lines in dcjax/ or experiments/ (`lint-imports` in .ci/run checks the import layers)."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_MODULE, MAX_FUNCTION = 500, 100


@pytest.mark.parametrize("folder", ["dcjax", "experiments"])
def test_modules_and_functions_are_small(folder):
    too_long = []
    for path in sorted((ROOT / folder).rglob("*.py")):
        text = path.read_text()
        rel = path.relative_to(ROOT)
        if text.count("\n") > MAX_MODULE:
            too_long.append(f"{rel}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.end_lineno - node.lineno + 1 > MAX_FUNCTION:
                too_long.append(f"{rel}:{node.lineno} {node.name}: {node.end_lineno - node.lineno + 1} lines")
    assert not too_long, too_long


def test_no_name_shadows_a_module():
    """`import dcjax.fitting.identify as m` gets the module: no package re-exports a name that is
    also one of its modules (dcjax.simulate, the function, vs a subpackage of that name was one)."""
    import importlib
    import pkgutil

    shadowed = []
    for name in (
        "dcjax",
        "dcjax.models",
        "dcjax.io",
        "dcjax.simulation",
        "dcjax.strategies",
        "dcjax.analysis",
        "dcjax.fitting",
        "dcjax.cli",
    ):
        package = importlib.import_module(name)
        for info in pkgutil.iter_modules(package.__path__):
            if info.name == "__main__":
                continue
            module = importlib.import_module(f"{name}.{info.name}")
            if getattr(package, info.name) is not module:
                shadowed.append(f"{name}.{info.name}")
    assert not shadowed, shadowed
