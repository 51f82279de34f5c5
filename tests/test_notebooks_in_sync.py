"""Each tutorial is a jupytext pair: ``notebooks/NAME.py`` (percent format, the source people read and lint) and
``notebooks/NAME.ipynb`` (what JupyterLab opens and nbval runs). Saving in JupyterLab updates both
(``notebooks/jupytext.toml``), so the pair must hold the same cells; outputs a user saved into the working copy
are theirs and do not matter, but what git holds must carry none."""
import json
import shutil
import subprocess
from pathlib import Path

import jupytext
import pytest

REPO = Path(__file__).resolve().parents[1]
NB_DIR = REPO / "notebooks"
PAIRS = sorted(p.stem for p in NB_DIR.glob("*.ipynb"))


def _cells(nb):
    return [(c.cell_type, c.source.strip()) for c in nb.cells]


def test_every_notebook_has_its_source_and_back():
    assert PAIRS, "no notebooks found"
    assert PAIRS == sorted(p.stem for p in NB_DIR.glob("*.py"))


@pytest.mark.parametrize("name", PAIRS)
def test_pair_holds_the_same_cells(name):
    py = jupytext.read(NB_DIR / f"{name}.py")
    ipynb = jupytext.read(NB_DIR / f"{name}.ipynb")
    assert _cells(py) == _cells(ipynb), (f"{name}.py and {name}.ipynb differ: run "
                                         f"`.venv/bin/jupytext --sync notebooks/{name}.py`")


def _committed(path: Path) -> str | None:
    """The text git holds for ``path`` (HEAD), or None when this is not a git checkout holding it."""
    if shutil.which("git") is None:
        return None
    r = subprocess.run(["git", "show", f"HEAD:{path.relative_to(REPO).as_posix()}"], cwd=REPO,
                       capture_output=True, text=True, timeout=30)
    return r.stdout if r.returncode == 0 else None


@pytest.mark.parametrize("name", PAIRS)
def test_committed_notebook_has_no_outputs(name):
    path = NB_DIR / f"{name}.ipynb"
    text = _committed(path)
    if text is None:   # an export without git history: the files themselves are what was shipped
        text = path.read_text(encoding="utf-8")
    for i, c in enumerate(json.loads(text)["cells"]):
        assert not c.get("outputs"), f"{name}.ipynb cell {i} is committed with outputs"
        assert c.get("execution_count") is None, f"{name}.ipynb cell {i} is committed with an execution count"
