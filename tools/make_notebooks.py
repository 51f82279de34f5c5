"""Write the tutorial notebooks in ``notebooks/`` from one source of truth (this script).

usage:  .venv/bin/python tools/make_notebooks.py            # writes notebooks/0*.ipynb (no outputs)
        .venv/bin/python tools/make_notebooks.py --check    # exit 1 if a committed notebook differs

The notebooks are written without outputs (nbformat v4) so git never holds plots or widget state.
Each notebook runs top to bottom on a fresh kernel, reads only the sample clips in ``data/`` (made by
``python -m stagger_nb.data.prepare``) and checks its key numbers with plain ``assert`` statements, so
``pytest --nbval-lax notebooks/`` is a real test of the tutorials.

Code shared by several notebooks (the static skeleton figure) is written once here and inserted into each
notebook that needs it, so a notebook stays self-contained for a reader.
"""
from __future__ import annotations

import argparse
import sys
import textwrap
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

ROOT = Path(__file__).resolve().parents[1]
NB_DIR = ROOT / "notebooks"

KERNELSPEC = {"display_name": "Python 3 (ipykernel)", "language": "python", "name": "python3"}


class Book:
    """An ordered list of cells; ``md`` and ``code`` dedent their text."""

    def __init__(self, name: str):
        self.name = name
        self.cells = []

    def md(self, text: str) -> "Book":
        self.cells.append(new_markdown_cell(textwrap.dedent(text).strip("\n")))
        return self

    def code(self, text: str, tags: tuple[str, ...] = ()) -> "Book":
        cell = new_code_cell(textwrap.dedent(text).strip("\n"))
        if tags:
            cell.metadata["tags"] = list(tags)
        self.cells.append(cell)
        return self

    def notebook(self):
        nb = new_notebook(cells=self.cells)
        nb.metadata["kernelspec"] = KERNELSPEC
        nb.metadata["language_info"] = {"name": "python"}
        # stable cell ids so regenerating an unchanged notebook gives an identical file
        for i, c in enumerate(nb.cells):
            c["id"] = f"{self.name[:2]}-{i:03d}"
        return nb


# --------------------------------------------------------------------------------------------------------
# Shared snippets (inserted verbatim into the notebooks that use them)
# --------------------------------------------------------------------------------------------------------

SKELETON_FIGURE = '''
def skeleton_figure(positions, parents, frames, colors=None, names=None, title=""):
    """Static 3D plotly figure of the skeleton at several frames (a strobe).

    positions : (F, J, 3) world joint positions from sn.forward_kinematics; parents : (J,), root = -1;
    frames : frame indices to draw; colors / names : one per frame (optional).
    """
    fig = go.Figure()
    bones = [(j, p) for j, p in enumerate(parents) if p >= 0]
    for n, f in enumerate(frames):
        xyz = [[], [], []]
        for j, p in bones:                      # one polyline with None gaps between bones
            for a in range(3):
                xyz[a] += [positions[f, p, a], positions[f, j, a], None]
        fig.add_trace(go.Scatter3d(
            x=xyz[0], y=xyz[1], z=xyz[2], mode="lines",
            line=dict(width=5, color=None if colors is None else colors[n]),
            name=(names[n] if names is not None else f"frame {f}")))
    # BVH is y-up; plotly's 3D camera is z-up by default, so look along -z with y up
    fig.update_layout(title=title, height=420, margin=dict(l=0, r=0, t=40, b=0),
                      scene=dict(aspectmode="data", camera=dict(up=dict(x=0, y=1, z=0),
                                                              eye=dict(x=0.2, y=0.6, z=2.2))))
    return fig
'''


# --------------------------------------------------------------------------------------------------------
# 00 quickstart
# --------------------------------------------------------------------------------------------------------

def quickstart() -> Book:
    b = Book("00_quickstart")
    b.md("""
    # stagger_nb quickstart

    **stagger_nb** edits skeletal motion capture (BVH) in Jupyter with three techniques from the literature:

    | technique | paper | what you control |
    |---|---|---|
    | staggered poses | Coleman, Bibliowicz, Singh & Gleicher 2008 | a few extreme poses and the *timing* among body parts |
    | magic wand | Dean, Lewis & Chalmers 2018 | one edited frame; the data decides how far the edit reaches |
    | guided time warping | Hsu, da Silva & Popović 2007 | the duration; a reference motion decides the timing |

    This notebook takes one clip through all of it in a few cells: load, look, one edit with each technique,
    export a BVH file and save the edit session. The other notebooks (01, 02, 03) walk through each paper.

    Conventions: times are seconds, frame ranges are half-open, quaternions are `(x, y, z, w)`.
    """)
    b.code("""
    import tempfile
    from pathlib import Path

    import numpy as np
    import plotly.graph_objects as go

    import stagger_nb as sn
    from stagger_nb import staggered, wand, timewarp

    walk = sn.data.load("walk")            # a sample clip from data/ (made by `make lab` / `make test`)
    print(walk.num_frames, "frames at", round(1 / walk.frame_time), "Hz;", walk.skeleton.num_joints, "joints")
    print(walk.skeleton.names)
    assert walk.local_quats.shape == (walk.num_frames, walk.skeleton.num_joints, 4)
    """)
    b.md("""
    ## Any BVH file

    `sn.read_bvh(path)` reads any BVH file into a frozen `Motion`; `sn.write_bvh(motion, path)` writes one.
    Here we read the CMU sample clip by its path. (Replace the path with your own file.)
    """)
    b.code("""
    path = sn.data.path("cmu_01_01")       # or any other .bvh path on your machine
    cmu = sn.read_bvh(path)
    print(path.name, cmu.num_frames, "frames,", round(cmu.duration, 2), "s,", cmu.skeleton.num_joints, "joints")
    assert cmu.num_frames > 100 and cmu.frame_time > 0
    """)
    b.md("""
    ## Look at it

    Forward kinematics turns the joint rotations into world positions, `(F, J, 3)`. A static strobe of a few
    frames is a plotly figure; the interactive `SkeletonView` plays the clip in 3D (drag to orbit, the slider
    scrubs time).
    """)
    b.code(SKELETON_FIGURE + """

    positions, world_quats = sn.forward_kinematics(walk)
    frames = np.linspace(0, walk.num_frames - 1, 6).astype(int)
    skeleton_figure(positions, walk.skeleton.parents, frames, title="walk: six frames").show()
    """)
    b.code("""
    from stagger_nb.widgets import SkeletonView
    SkeletonView(walk)
    """)
    return b


def staggered_nb() -> Book:
    b = Book("01_staggered_poses")
    b.md("""
    # Staggered poses (Coleman et al. 2008)

    A *staggered pose* is a key pose whose degrees of freedom reach their extreme values at slightly different
    times: each joint `i` of pose `k` has a value $v_{k,i}$ and a *timing refinement* $r_{k,i}$, so its knot sits
    at $t_k + r_{k,i}$ (paper §3, Fig. 1). Between poses, a spline carries the low-frequency transition and a
    displacement map keeps every detail of the captured motion (Fig. 3). Editing the few poses changes the
    stance; editing the refinements changes the *coordination* — succession down a limb, or random asymmetry.

    This notebook follows the paper: find the poses in dense motion capture (§4.1, Fig. 4 and 5), fit splines
    and displacement maps (§4.1.1, Fig. 3), edit a pose geometrically (§5.1, Fig. 6), edit the timing with
    linear and nonlinear succession and random offsets (§5.2, Fig. 7), and keep the feet planted (App. B).
    """)
    return b


def wand_nb() -> Book:
    b = Book("02_magic_wand")
    b.md("""
    # The magic wand (Dean, Lewis & Chalmers 2018)

    Edit one frame; let the motion itself decide how the edit fades in and out. The falloff is the Green's
    function of the *pose-space Laplacian*: a Gaussian kernel between all pairs of poses (Eq. 1), normalised
    (Eq. 2), its Laplacian's eigenvectors, and the Green's function $G(p_i, p_j) = \\sum_{k>0}
    \\phi_k(p_i)\\phi_k(p_j)/\\lambda_k$ (Eq. 3). The edit is a log-quaternion delta (Eq. 4) added with weight
    $w_{ij}$ (Eq. 5): 1 at the edited frame, 0 at the most dissimilar frame of the chosen range.
    """)
    return b


def timewarp_nb() -> Book:
    b = Book("03_guided_time_warping")
    b.md("""
    # Guided time warping (Hsu, da Silva & Popović 2007)

    A time warp changes *when* poses happen, never the poses. Given keytimes (at least a new duration) and a
    *reference motion*, guided time warping picks a subsequence of input frames (complete: first and last frame
    kept, no gap larger than `s` frames; monotonic) whose local velocities and accelerations look most like the
    reference's (§3.1–3.2), found exactly by a constrained shortest-path dynamic programme (§3.3), then smooths
    the warp and resamples with slerp (§3.4).
    """)
    return b


BOOKS = [quickstart, staggered_nb, wand_nb, timewarp_nb]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="only compare with the files on disk")
    a = ap.parse_args(argv)
    NB_DIR.mkdir(exist_ok=True)
    stale = []
    for make in BOOKS:
        book = make()
        nb = book.notebook()
        nbformat.validate(nb)
        text = nbformat.writes(nb) + "\n"
        path = NB_DIR / f"{book.name}.ipynb"
        if a.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(path.name)
        else:
            path.write_text(text)
            print("wrote", path.relative_to(ROOT), f"({len(nb.cells)} cells)")
    if stale:
        print("out of date (run tools/make_notebooks.py):", ", ".join(stale))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
