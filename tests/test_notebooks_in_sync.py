"""The committed notebooks are exactly what tools/make_notebooks.py writes (one source of truth, no outputs)."""
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_notebooks_match_their_generator():
    r = subprocess.run([sys.executable, str(REPO / "tools" / "make_notebooks.py"), "--check"],
                       capture_output=True, text=True, cwd=REPO)
    assert r.returncode == 0, r.stdout + r.stderr


def test_notebooks_are_committed_without_outputs():
    for nb in sorted((REPO / "notebooks").glob("*.ipynb")):
        cells = json.loads(nb.read_text())["cells"]
        for c in cells:
            assert not c.get("outputs"), f"{nb.name} has outputs"
            assert c.get("execution_count") is None, f"{nb.name} has execution counts"
