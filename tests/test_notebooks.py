"""The notebooks run top to bottom in a Jupyter kernel (nbclient), on a small budget."""

import json
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
EMPS = ROOT.parent / "shared" / "real" / "emps"  # the benchmark's data beside the checkout (CI has it)


def test_there_are_notebooks():
    assert {p.name for p in NOTEBOOKS} >= {
        "quickstart.ipynb",
        "controlled_drive.ipynb",
        "results_browser.ipynb",
        "real_benchmark_emps.ipynb",
    }


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_is_valid_with_an_id_on_every_cell(path):
    """nbformat 4.5's schema: a cell without an id is a warning today, an error in a later
    nbformat (`nbformat.read` would refuse the notebook)."""
    text = path.read_text(encoding="utf-8")
    ids = [c.get("id") for c in json.loads(text)["cells"]]  # as written (`nbformat.read` adds missing ids)
    assert all(ids) and len(set(ids)) == len(ids), ids
    nbformat.validate(nbformat.reads(text, as_version=4))


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.name)
def test_notebook_runs(path, tmp_path, monkeypatch):
    if path.name == "real_benchmark_emps.ipynb":  # it asserts IDIM-LS within 1 % and Fv, Fc, offset within 5 %
        if not (EMPS / "DATA_EMPS.mat").is_file():
            pytest.skip(f"EMPS data not in {EMPS}")
        monkeypatch.setenv("DCJAX_EMPS_DIR", str(EMPS))
    monkeypatch.setenv("DCJAX_NB_BUDGET", "1400")
    monkeypatch.setenv("DCJAX_NB_RUNS", "2")
    monkeypatch.setenv("DCJAX_STORE", str(tmp_path / "absent.jsonl"))  # the browser builds its own demo store
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(path, as_version=4)
    # dcjax's own DeprecationWarnings (a 0.1 name in a notebook) are errors
    nb.cells.insert(
        0,
        nbformat.v4.new_code_cell(
            'import warnings\nwarnings.filterwarnings("error", message=".*deprecated since dcjax", category=DeprecationWarning)'
        ),
    )
    NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    assert any(o.output_type in ("stream", "execute_result", "display_data") for o in outputs)
