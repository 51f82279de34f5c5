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

    def code(self, *parts: str, tags: tuple[str, ...] = ()) -> "Book":
        """One code cell from ``parts``, each dedented on its own (shared snippets + cell code)."""
        cell = new_code_cell("\n\n".join(textwrap.dedent(p).strip("\n") for p in parts))
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
def skeleton_figure(positions, parents, frames, colors=None, names=None, title="", view="side"):
    """Static 3D plotly figure of the skeleton at several frames (a strobe).

    positions : (F, J, 3) world joint positions from sn.forward_kinematics; parents : (J,), root = -1;
    frames : frame indices to draw; colors / names : one per frame (optional);
    view : "side" (from +x) or "front" (from +z: the clips face and travel along +z, y up).
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
    eye = dict(x=2.0, y=0.35, z=0.0) if view == "side" else dict(x=0.0, y=0.35, z=2.0)
    fig.update_layout(title=title, height=420, margin=dict(l=0, r=0, t=40, b=0),
                      scene=dict(aspectmode="data", camera=dict(up=dict(x=0, y=1, z=0), eye=eye,
                                                              projection=dict(type="orthographic"))))
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
    from stagger_nb.core.rotations import quat_angle

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
    b.code(SKELETON_FIGURE, """

    positions, world_quats = sn.forward_kinematics(walk)
    frames = np.linspace(0, walk.num_frames - 1, 6).astype(int)
    skeleton_figure(positions, walk.skeleton.parents, frames, title="walk: six frames").show()
    """)
    b.code("""
    from stagger_nb.widgets import SkeletonView
    SkeletonView(walk)
    """)
    b.md("""
    ## One edit with each technique, recorded in a session

    A `Session` is the source motion plus an ordered list of JSON operations; replaying them gives the
    edited motion, so every edit is reproducible, undoable and saveable. The same operations are plain
    functions in `staggered`, `wand` and `timewarp` (notebooks 01–03 use them directly).

    **Staggered poses** — nonlinear succession down the left arm: the hand's extremes now trail the
    shoulder's by $s\\,d^l$ seconds ($d$ = bones from the shoulder).
    """)
    b.code("""
    from stagger_nb.session import Session

    session = Session.from_bvh(sn.data.path("walk"))
    session.add({"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0})
    step1 = session.edited()

    # the same edit with the plain functions
    direct = staggered.evaluate(staggered.succession(staggered.extract(session.source), root="LeftShoulder",
                                                     s=0.03, l=2.0))
    assert np.allclose(step1.local_quats, direct.local_quats)
    elbow = walk.skeleton.index("LeftForeArm")
    lag = np.degrees(quat_angle(step1.local_quats[:, elbow], walk.local_quats[:, elbow]))
    print(f"the left elbow's rotation now differs by up to {lag.max():.1f} degrees (it moves later)")
    assert lag.max() > 1.0
    """)
    b.md("""
    **Magic wand** — rotate the left upper arm by 25° at one frame; the Green's-function falloff carries the
    edit to every similar pose of the walk.
    """)
    b.code("""
    frame = 120
    session.add({"op": "propagate", "frame": frame, "deltas": {"LeftArm": [0.0, 0.0, -25.0]}})
    step2 = session.edited()
    weight = wand.falloff(step1, frame)
    arm = walk.skeleton.index("LeftArm")
    change = np.degrees(quat_angle(step2.local_quats[:, arm], step1.local_quats[:, arm]))
    print(f"change at the edited frame {change[frame]:.1f} deg; frames with weight > 0.9: {np.sum(weight > 0.9)}")
    assert abs(change[frame] - 25.0) < 1e-6          # the edited frame gets the whole edit
    assert np.sum(weight > 0.9) > 3 * np.sum(np.abs(np.arange(walk.num_frames) - frame) <= 2)   # non-local
    """)
    b.md("""
    **Guided time warping** — make the clip 25 % shorter, with the motion as its own timing reference.
    """)
    b.code("""
    session.add({"op": "guided_warp", "duration": 0.75 * walk.duration})
    result = session.edited()
    warp = session.warp_curve()
    print(f"{walk.duration:.2f} s -> {result.duration:.2f} s; warp from {warp[0]:.2f} s to {warp[-1]:.2f} s")
    assert abs(result.duration - 0.75 * walk.duration) <= walk.frame_time
    assert np.all(np.diff(warp) > 0) and np.isclose(warp[-1], walk.duration)   # monotonic and complete
    print(session.ops)
    """)
    b.md("""
    ## Export and save

    `export_bvh` writes the edited motion (it refuses to overwrite the source file); `save` writes the session
    as JSON — the source by path and checksum, plus the op list. Loading and replaying gives the same motion.
    """)
    b.code("""
    out_dir = Path(tempfile.mkdtemp(prefix="stagger_nb_quickstart_"))
    session.export_bvh(out_dir / "walk_edited.bvh")
    session.save(out_dir / "walk_edited.session.json")

    back = sn.read_bvh(out_dir / "walk_edited.bvh")
    replayed = Session.load(out_dir / "walk_edited.session.json").edited()
    print(sorted(p.name for p in out_dir.iterdir()))
    assert back.num_frames == result.num_frames
    assert np.allclose(sn.forward_kinematics(back)[0], sn.forward_kinematics(result)[0], atol=1e-3)  # BVH text: 6 decimals
    assert np.allclose(replayed.local_quats, result.local_quats)
    """)
    b.md("""
    ## Interactive editing

    Each technique has an editor with sliders, the 3D view (the original as a grey ghost) and its plots; it
    edits the same kind of session, so what you do there can be saved and replayed the same way. Notebooks
    01–03 end with `StaggerEditor`, `WandEditor` and `WarpEditor`; here is the staggered-pose editor on the
    session above (drag the sliders, then `editor.session.save(...)`).
    """)
    b.code("""
    from stagger_nb.widgets import StaggerEditor
    editor = StaggerEditor(session)
    editor
    """)
    return b


def staggered_nb() -> Book:
    b = Book("01_staggered_poses")
    b.md("""
    # Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008)

    A *staggered pose* is a key pose whose degrees of freedom reach their extreme values at slightly different
    times: each joint `i` of pose `k` has a value $v_{k,i}$ and a *timing refinement* $r_{k,i}$, so its knot sits
    at $t_k + r_{k,i}$ (paper §3, Fig. 1). Between poses, a spline carries the low-frequency transition and a
    displacement map keeps every detail of the captured motion (Fig. 3). Editing the few poses changes the
    stance; editing the refinements changes the *coordination* — succession down a limb, or random asymmetry.

    This notebook follows the paper: find the poses in dense motion (§4.1, Fig. 4 and 5), fit splines and
    displacement maps (§4.1.1, Fig. 3), edit a pose geometrically (§5.1, Fig. 6), edit the timing with linear
    and nonlinear succession and random offsets (§5.2, Fig. 7), and keep the feet planted (§3, App. B).

    ```python
    sm = staggered.extract(m)            # all candidate poses, refinements, splines, displacement maps
    sm = staggered.cull(sm, percent=50)  # keep the highest-priority half
    sm = staggered.succession(sm, root="LeftShoulder", s=0.03, l=2.0)
    m2 = staggered.evaluate(sm)          # back to a dense Motion
    ```
    """)
    b.code("""
    import dataclasses

    import numpy as np
    import plotly.graph_objects as go
    import plotly.express as px
    from plotly.subplots import make_subplots

    import stagger_nb as sn
    from stagger_nb import staggered
    from stagger_nb.core.rotations import quat_angle, quat_mul, quat_conj, quat_to_rotvec
    from stagger_nb.staggered.extraction import pose_priorities, pose_probability

    run = sn.data.load("run")
    walk = sn.data.load("walk")
    print(f"run: {run.num_frames} frames, walk: {walk.num_frames} frames at {1 / run.frame_time:.0f} Hz")
    sm_run = staggered.extract(run)
    K, J = sm_run.refinements.shape
    print(f"run: {K} candidate staggered poses at", np.round(sm_run.pose_times, 2), "s")
    assert np.allclose(staggered.evaluate(sm_run).local_quats, run.local_quats, atol=1e-9)   # exact representation
    """)
    b.md("""
    ## Figure 4 — evidence signals

    For every joint, the *scaled curvature* $\\hat\\kappa = n\\cdot e/|e| \\in [0, 1]$ of the local-space motion
    trails of its limb axes (two trails per child, so twist counts too), smoothed; the root translation gets
    its own trail, and contact starts and ends are a binary global signal. Peaks mark direction changes.
    They *cluster*: many body parts change direction at nearly the same time, slightly staggered — the grey
    lines are the extracted pose times.
    """)
    b.code("""
    evidence = sm_run.metadata["evidence"]          # (F, J + 2): joints, root translation, contact events
    weights = sm_run.metadata["weights"]            # (J + 2,)
    columns = list(run.skeleton.names) + ["root translation", "contact events"]
    shown = ["LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg", "LowerBack", "LeftArm", "RightArm",
             "LeftForeArm", "root translation", "contact events"]
    fig = go.Figure()
    for n, name in enumerate(shown):
        c = columns.index(name)
        fig.add_trace(go.Scatter(x=run.times, y=evidence[:, c] + 1.1 * (len(shown) - 1 - n), name=name,
                                 mode="lines", line_width=1.5))
    for t in sm_run.pose_times:
        fig.add_vline(x=t, line_color="gray", line_width=1, opacity=0.5)
    fig.update_layout(title="Fig. 4: evidence signals p_i(t) of a run (offset for display), pose times in grey",
                      xaxis_title="time (s)", yaxis=dict(showticklabels=False), height=520)
    fig.show()
    assert evidence.min() >= 0 and evidence.max() <= 1      # probabilities (the modified curvature is clamped)
    """)
    b.md("""
    ## Figure 5 — the pose probability signal, candidates and priorities

    The weighted mean of the signals ($w_i$ = limb length × trail arc length: limbs that move a lot count
    more) is low-pass filtered with a 0.15 s tent, which merges each cluster into one peak: the *pose
    probability* $P(t)$. Every local maximum (plus the first and last frame) is a candidate pose. Each gets the
    priority $w_k = P(t_k)(t_{k+1} - t_{k-1})$, favouring likely poses with distant neighbours; culling keeps
    the highest-priority fraction.
    """)
    b.code("""
    P = sm_run.metadata["probability"]
    raw = evidence @ weights / weights.sum()
    frames = np.round(sm_run.pose_times / run.frame_time).astype(int)
    prio = pose_priorities(sm_run.pose_times, sm_run.pose_probability)    # (K,)
    kept = staggered.cull(sm_run, percent=50)
    is_kept = np.isin(np.round(sm_run.pose_times, 9), np.round(kept.pose_times, 9))

    fig = go.Figure()
    fig.add_trace(go.Scatter(x=run.times, y=raw, name="weighted mean of the evidence", line_color="lightgray"))
    fig.add_trace(go.Scatter(x=run.times, y=P, name="pose probability P(t) (tent filtered)", line_color="black"))
    fig.add_trace(go.Scatter(x=sm_run.pose_times[is_kept], y=P[frames[is_kept]], mode="markers",
                             marker=dict(size=11, color="crimson"), name="kept by cull(percent=50)"))
    fig.add_trace(go.Scatter(x=sm_run.pose_times[~is_kept], y=P[frames[~is_kept]], mode="markers",
                             marker=dict(size=9, color="royalblue", symbol="circle-open", line_width=2),
                             name="culled candidates"))
    fig.update_layout(title="Fig. 5: pose probability, candidate poses and culling by priority",
                      xaxis_title="time (s)", yaxis_title="probability", height=360)
    fig.show()

    assert np.allclose(pose_probability(evidence, weights, run.frame_time), P)     # P is the filtered mean
    interior = frames[1:-1]
    assert np.all(P[interior] >= P[interior - 1]) and np.all(P[interior] >= P[interior + 1])   # peaks of P
    n_kept = len(kept.pose_times)
    assert n_kept == int(np.ceil(0.5 * K)) and is_kept[0] and is_kept[-1]
    # the kept interior poses are exactly the highest-priority ones
    assert set(np.flatnonzero(is_kept)[1:-1]) == set(np.argsort(-prio[1:-1])[: n_kept - 2] + 1)
    """)
    b.md("""
    ### Timing refinements

    For each pose and joint, the refinement is the offset of the nearest peak of that joint's own evidence
    (within 0.25 s and closer to this pose than to the neighbours; 0 if none). The table shows how the
    extremes of a run's stance are staggered across the body, in milliseconds.
    """)
    b.code("""
    fig = go.Figure(go.Heatmap(z=1000 * sm_run.refinements.T, x=[f"{t:.2f}" for t in sm_run.pose_times],
                               y=list(run.skeleton.names), colorscale="RdBu", zmid=0,
                               colorbar_title="ms"))
    fig.update_layout(title="Timing refinements r_k,i (ms): pose time (columns) x joint (rows)",
                      xaxis_title="pose time t_k (s)", height=620)
    fig.show()
    print(f"{np.count_nonzero(sm_run.refinements)} of {K * J} knots are staggered; "
          f"largest |r| = {1000 * np.abs(sm_run.refinements).max():.0f} ms")
    assert np.abs(sm_run.refinements).max() <= 0.25 + 1e-9          # the paper's 0.25 s bound
    assert np.all(sm_run.refinements[[0, -1]] == 0)                 # first and last poses are not staggered
    """)
    b.md("""
    ## Figure 3 — splines and displacement maps

    Between two staggered poses each joint follows a cubic quaternion spline (recursive slerp, fitted to the
    samples, App. A) in a normalised time $t'$ between its own refined knots, composed with a displacement
    map that holds whatever the spline misses: $v_i(t) = s_i(t') \\oplus d_i(t')$. Below, the main rotation
    channel of two joints of the run: the data, the spline alone (displacement maps set to zero), the
    knots at the refined times, and the displacement. For the upper arm the spline carries the movement and
    the displacement is small detail, as in the paper's figure. The knee bends twice per stride — more often
    than there are staggered poses — so there the displacement map carries a large part of the movement;
    the sum is still exact.
    """)
    b.code("""
    no_detail = dataclasses.replace(
        sm_run, displacements=np.zeros_like(sm_run.displacements),
        root_displacements=np.zeros_like(sm_run.root_displacements))
    spline_only = staggered.evaluate(no_detail)
    full = staggered.evaluate(sm_run)
    knots_t = staggered.knot_times(sm_run)

    def channel(q, axis):
        # one component of the rotation vector, in degrees
        return np.degrees(quat_to_rotvec(q)[..., axis])

    shown = {"LeftArm": None, "LeftLeg": None}
    fig = make_subplots(rows=2, cols=2, shared_xaxes=True, row_heights=[0.68, 0.32], horizontal_spacing=0.08,
                        subplot_titles=("left upper arm (degrees)", "left knee (degrees)",
                                        "displacement map", "displacement map"))
    for col, name in enumerate(shown, start=1):
        j = run.skeleton.index(name)
        axis = int(np.argmax(np.ptp(quat_to_rotvec(run.local_quats[:, j]), axis=0)))   # its main channel
        disp = np.degrees(quat_to_rotvec(quat_mul(quat_conj(spline_only.local_quats[:, j]),
                                                  full.local_quats[:, j]))[:, axis])
        shown[name] = (np.abs(disp).max(), np.ptp(channel(run.local_quats[:, j], axis)))
        first = col == 1
        fig.add_trace(go.Scatter(x=run.times, y=channel(run.local_quats[:, j], axis), mode="markers",
                                 marker_size=3, marker_color="gray", name="motion data", showlegend=first), 1, col)
        fig.add_trace(go.Scatter(x=run.times, y=channel(spline_only.local_quats[:, j], axis), line_color="crimson",
                                 name="spline s(t')", showlegend=first), 1, col)
        fig.add_trace(go.Scatter(x=knots_t[:, j], y=channel(sm_run.values[:, j], axis), mode="markers",
                                 marker=dict(size=8, color="royalblue"), name="knots at t_k + r_k,i",
                                 showlegend=first), 1, col)
        fig.add_trace(go.Scatter(x=run.times, y=disp, line_color="green", name="displacement d(t')",
                                 showlegend=first), 2, col)
    fig.update_xaxes(title_text="time (s)", row=2)
    fig.update_layout(title="Fig. 3: spline (red) + displacement map (green) = the data", height=500)
    fig.show()

    err = np.degrees(quat_angle(full.local_quats, run.local_quats)).max()
    for name, (d, rng) in shown.items():
        print(f"{name}: displacement up to {d:.1f} degrees on a channel spanning {rng:.1f} degrees")
    print(f"reconstruction error of the whole motion: {err:.1e} degrees")
    assert err < 1e-6                                        # spline + displacement reproduce the data exactly
    assert shown["LeftArm"][0] < 0.05 * shown["LeftArm"][1]  # the arm's spline carries the movement
    assert shown["LeftArm"][0] > 0.01                        # and its displacement map still holds detail
    """)
    b.md("""
    ## Figure 6 — geometric editing of a pose and of the non-staggered pose

    Two poses belong to each staggered pose: the *pose at the staggered pose time* (every joint evaluated at
    $t_k$: the editing knots $v^0_{k,i}$) and the *non-staggered pose* (every joint at its extreme value
    $v_{k,i}$). The non-staggered pose never occurs in the motion; it usually looks like an exaggeration of
    the true pose. `edit_pose` edits either one (`mode="staggered"` or `"unstaggered"`) and carries the same
    change to the other knot, so the motion stays continuous (§5.1). Here: the walk's arms, a 0.35 rad turn
    of both upper arms, edited at one pose.
    """)
    b.code(SKELETON_FIGURE, """

    sm_walk = staggered.extract(walk)
    k = int(np.argmax(np.abs(sm_walk.refinements[1:-1]).sum(axis=1))) + 1      # the most staggered pose
    t_k = sm_walk.pose_times[k]
    true_pose = sm_walk.editing_knots[k]
    non_staggered = sm_walk.values[k]
    arms = {"LeftArm": [0.0, 0.0, -0.35], "RightArm": [0.0, 0.0, 0.35]}

    def pose_positions(quats, root):
        m1 = walk.slice(0, 1).replace(local_quats=quats[None], root_positions=root[None])
        return sn.forward_kinematics(m1)[0][0]

    root_k = walk.root_positions[int(round(t_k / walk.frame_time))]
    edit_true = staggered.edit_pose(sm_walk, k, deltas=arms, mode="staggered")
    edit_ns = staggered.edit_pose(sm_walk, k, deltas=arms, mode="unstaggered")
    shapes = np.stack([pose_positions(q, root_k) for q in
                       (true_pose, non_staggered, edit_true.editing_knots[k], edit_ns.values[k])])
    shapes[2:, :, 0] += 90          # edited poses to the right
    skeleton_figure(shapes, walk.skeleton.parents, range(4), colors=["gold", "orange", "gold", "orange"],
                    names=["pose at t_k", "non-staggered pose", "pose at t_k, edited", "non-staggered, edited"],
                    title=f"Fig. 6: pose {k} (t = {t_k:.2f} s) true (yellow) and non-staggered (orange); "
                          "right: after the arm edit", view="front").show()

    mean = staggered.mean_pose(sm_walk.values)
    staggered_knots = sm_walk.refinements != 0
    further = (quat_angle(sm_walk.values, mean[None]) >= quat_angle(sm_walk.editing_knots, mean[None]) - 1e-9)
    print(f"non-staggered value further from the mean pose than the true pose for "
          f"{100 * further[staggered_knots].mean():.0f}% of the staggered knots")
    # the edited true pose is what the motion passes through at t_k, and the change is the same on both knots
    at_tk = staggered.evaluate(edit_true, [t_k]).local_quats[0]
    j = walk.skeleton.index("LeftArm")
    assert quat_angle(at_tk[j], edit_true.editing_knots[k, j]) < 1e-6
    for e in (edit_true, edit_ns):
        change_v = quat_mul(quat_conj(sm_walk.values[k, j]), e.values[k, j])
        change_v0 = quat_mul(quat_conj(sm_walk.editing_knots[k, j]), e.editing_knots[k, j])
        assert quat_angle(change_v, change_v0) < 1e-6
    # motion outside the neighbouring poses is untouched
    before = staggered.evaluate(edit_true).local_quats
    far = (walk.times < sm_walk.pose_times[k - 1] - 0.3) | (walk.times > sm_walk.pose_times[k + 1] + 0.3)
    assert np.allclose(quat_angle(before[far], walk.local_quats[far]), 0, atol=1e-6)
    """)
    b.md("""
    ## Figure 7 — temporal editing: linear and nonlinear succession, random timing

    Succession shifts refinements down a chain: $\\hat r_{k,i} = r_{k,i} + s\\,d(i)^l$, with $d(i)$ the number
    of bones from a chosen joint. $l = 1$ is Neff & Fiume's linear succession; larger $l$ makes the limb look
    looser, more cartoony. Random timing adds $U(-\\tau, \\tau)$ per knot (seeded). As in the paper's Fig. 7,
    we first widen the arm swing on the non-staggered poses (`exaggerate` relative to the mean pose), then
    loosen the arms with nonlinear succession from the shoulders. Plotted: the left elbow's rotation in the
    original (c), after the geometric edit (d), and after geometric + temporal edits with $l = 1$ and $l = 2$ (e).
    """)
    b.code("""
    arm_chain = ["LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand"]
    arm_joints = arm_chain + ["RightShoulder", "RightArm", "RightForeArm", "RightHand"]
    interior = list(range(1, len(sm_walk.pose_times) - 1))
    geo = staggered.exaggerate(sm_walk, interior, 0.5, reference="mean", mode="unstaggered", joints=arm_joints)
    variants = {"(c) original": sm_walk, "(d) geometric": geo}
    for l in (1.0, 2.0):
        tmp = staggered.succession(geo, root="LeftShoulder", s=0.03, l=l)
        variants[f"(e) + succession l={l:g}"] = staggered.succession(tmp, root="RightShoulder", s=0.03, l=l)

    elbow = walk.skeleton.index("LeftForeArm")
    fig = go.Figure()
    for (name, v), color in zip(variants.items(), ["gray", "royalblue", "orange", "crimson"]):
        mv = staggered.evaluate(v)
        fig.add_trace(go.Scatter(x=mv.times, y=np.degrees(quat_angle(mv.local_quats[:, elbow])), name=name,
                                 line_color=color))
    fig.update_layout(title="Fig. 7: left elbow angle — original, geometric edit, + linear / nonlinear succession",
                      xaxis_title="time (s)", yaxis_title="elbow rotation (degrees)", height=380)
    fig.show()

    depth = np.arange(len(arm_chain))
    for l in (1.0, 2.0):
        added = variants[f"(e) + succession l={l:g}"].refinements - geo.refinements
        got = added[interior][:, [walk.skeleton.index(n) for n in arm_chain]]
        assert np.allclose(got, 0.03 * depth ** l)           # r + s d(i)^l, exactly, on every interior pose
        print(f"l = {l:g}: added refinements down the left arm {np.round(1000 * got[0]).astype(int)} ms; "
              f"{len(staggered.timing_warnings(variants[f'(e) + succession l={l:g}']))} timing warnings")

    rnd = staggered.random_timing(sm_walk, joints=arm_joints, tau=0.05, seed=7)
    delta = rnd.refinements - sm_walk.refinements
    assert np.abs(delta).max() <= 0.05 and np.abs(delta).max() > 0.03   # bounded by tau, and really used
    assert np.array_equal(staggered.random_timing(sm_walk, joints=arm_joints, tau=0.05, seed=7).refinements,
                          rnd.refinements)                                    # reproducible with the seed
    legs = [walk.skeleton.index(n) for n in ("LeftUpLeg", "RightUpLeg")]
    assert np.all(delta[:, legs] == 0)                                        # only the chosen joints move
    """)
    b.md("""
    ## Contacts kept planted

    Timing edits move feet that should stay on the ground. Contacts are found by looking for end effectors
    that stay still for at least 0.25 s (App. B); after an edit, a constraint displacement layer (two-bone IK
    on each leg, faded in and out over 0.15 s) puts them back where the original motion had them (§3). Here a
    deliberately rough edit — succession from the hips plus random timing on every joint — makes the feet
    slide; the constraint layer removes most of the slide.
    """)
    b.code("""
    contacts = staggered.detect_contacts(walk)
    print(len(contacts), "contacts, e.g.", contacts[:3])
    rough = staggered.random_timing(staggered.succession(sm_walk, root="Hips", s=0.02, l=1.0), tau=0.05, seed=1)
    edited = staggered.evaluate(rough)
    fixed = staggered.apply_contact_constraints(edited, contacts, reference=walk)
    skate = {name: staggered.foot_skate(m, contacts).sum() for name, m in
             (("original", walk), ("edited", edited), ("edited + constraints", fixed))}
    print({k: round(float(v), 1) for k, v in skate.items()}, "(cm of horizontal sliding, all contacts)")

    ankle = walk.skeleton.index("RightFoot")
    fig = go.Figure()
    for name, m, color in (("original", walk, "gray"), ("edited", edited, "orange"),
                           ("edited + constraints", fixed, "crimson")):
        pos = sn.forward_kinematics(m)[0]
        fig.add_trace(go.Scatter(x=pos[:, ankle, 2], y=pos[:, ankle, 1], name=name, line_color=color))
    fig.update_layout(title="Right ankle path (side view): the edit makes it slide, the constraints plant it",
                      xaxis_title="forward (cm)", yaxis_title="height (cm)", height=330)
    fig.show()

    errors = staggered.contact_errors(fixed, contacts, reference=walk, mode="track")
    ankles = [i for i, c in enumerate(contacts) if c[0].endswith("Foot")]
    print(f"ankle contact error after constraints: max {errors[ankles].max():.2f} cm")
    assert skate["edited"] > 3 * skate["original"]            # the rough edit really breaks the contacts
    assert skate["edited + constraints"] < 0.2 * skate["edited"]
    assert errors[ankles].max() < 3.0                          # ankles back within 3 cm of the original track
    """)
    b.md("""
    ## The staggered-pose editor

    Everything above, interactively. The 3D view plays the edited walk with the original as a grey ghost;
    below it, the joint curves with the pose times and refinement knots, and the pose probability with the
    candidate and kept poses. The sliders set the percentage of poses kept (culling by priority), the
    succession root, `s` and `l`, random timing `τ` and seed, and exaggeration `w_r`. Every change is an op
    in `editor.session` (undo / redo buttons; `editor.session.save(path)` keeps it).
    """)
    b.code("""
    from stagger_nb.widgets import StaggerEditor
    editor = StaggerEditor(walk)
    editor
    """)
    return b


def wand_nb() -> Book:
    b = Book("02_magic_wand")
    b.md("""
    # The magic wand (Dean, Lewis & Chalmers 2018)

    Edit one frame; let the motion itself decide how the edit fades in and out. The falloff is the Green's
    function of the *pose-space Laplacian*: a Gaussian kernel between all pairs of poses (Eq. 1), normalised
    (Eq. 2), the eigenvectors $\\phi_k$ and eigenvalues $\\lambda_k$ of its Laplacian, and the Green's function
    $G(p_i, p_j) = \\sum_{k>0} \\phi_k(p_i)\\phi_k(p_j)/\\lambda_k$ (Eq. 3). The edit is a log-quaternion
    delta (Eq. 4) added to every frame $j$ with weight $w_{ij}$ (Eq. 5): 1 at the edited frame, 0 at the most
    dissimilar frame of the chosen range.

    Like the paper we work at 30 Hz: the sample clips (60 Hz) are resampled with slerp.
    The pipeline has a cached head and a cheap tail, which is what makes a σ slider interactive:

    ```python
    graph = wand.pose_graph(m)        # pose vectors + all pose distances (once per clip)
    basis = graph.basis(sigma)        # eigenpairs of the Laplacian for one kernel width
    w = wand.greens_falloff(basis, frame, frame_range)   # (F,) in [0, 1]
    ```
    """)
    b.code("""
    import numpy as np
    import plotly.graph_objects as go
    import plotly.express as px

    import stagger_nb as sn
    from stagger_nb import wand
    from stagger_nb.core.rotations import quat_mul, rotvec_to_quat

    walk = sn.data.load("walk").resample(1 / 30)
    run = sn.data.load("run").resample(1 / 30)
    print("walk:", walk.num_frames, "frames; run:", run.num_frames, "frames at 30 Hz")
    """)
    b.md("""
    ## Figure 1 — Green's distance from one control frame

    The normalised pose distance $1 - w$ from frame 53 of the walk to every frame. It is 0 at the control
    frame (the yellow bar: the pose compared with itself) and dips again wherever the walk comes back to a
    similar pose: the gait is quasi-periodic, so the distance is too. Its small dents, bends and plateaus
    follow the phases of the step.
    """)
    b.code("""
    control = 53
    walk_graph = wand.pose_graph(walk)
    walk_basis = walk_graph.basis()                 # sigma = the data-derived default
    d_walk = wand.greens_distance(walk_basis, control)

    fig = go.Figure(go.Scatter(x=np.arange(walk.num_frames), y=d_walk, mode="lines", name="Green's distance"))
    fig.add_vline(x=control, line_color="gold", line_width=6, opacity=0.6)
    fig.update_layout(title=f"Fig. 1: Green's function distance from frame {control} (walk, sigma = "
                            f"{walk_basis.sigma:.3f})", xaxis_title="frame", yaxis_title="normalised distance",
                      height=320)
    fig.show()

    # 0 at the control frame, 1 at the most dissimilar frame, and a later step brings the pose back
    assert d_walk[control] == 0 and np.isclose(d_walk.max(), 1)
    far = np.abs(np.arange(walk.num_frames) - control) > 15
    print("closest pose in another step:", np.round(d_walk[far].min(), 3))
    assert d_walk[far].min() < 0.2            # the walk is quasi-periodic: some other step is similar
    """)
    b.md("""
    ## Figure 2 — a motion that is not periodic

    The real CMU clip 01_01: the actor jumps forward a few times, stops, turns around and comes back. The
    distance from a frame early in the clip has bends at the transitions between phases rather than a
    clean period; where an edit should stop is not obvious from the curve alone, which is why the artist
    chooses the frame range.
    """)
    b.code("""
    cmu = sn.data.load("cmu_01_01").resample(1 / 30)
    cmu_basis = wand.pose_graph(cmu).basis()
    cmu_control = 60
    d_cmu = wand.greens_distance(cmu_basis, cmu_control)

    fig = go.Figure(go.Scatter(x=cmu.times, y=d_cmu, mode="lines", name="Green's distance"))
    fig.add_vline(x=cmu.times[cmu_control], line_color="gold", line_width=6, opacity=0.6)
    fig.update_layout(title=f"Fig. 2: Green's distance from frame {cmu_control} of CMU 01_01 "
                            f"({cmu.num_frames} frames at 30 Hz)",
                      xaxis_title="time (s)", yaxis_title="normalised distance", height=320)
    fig.show()
    assert d_cmu[cmu_control] == 0 and np.isclose(d_cmu.max(), 1)
    """)
    b.md("""
    ## Figure 3 — Green's function vs ISOMAP vs diffusion distance

    Two manifold-learning distances for comparison, on the run cycle, from frame 53: ISOMAP (geodesic
    shortest paths in a k-nearest-neighbour graph) and the diffusion distance after 10 random-walk steps.
    All three find the same periodic structure (left). Zoomed in near the control frame (right), the
    Green's distance is *rounded*, the diffusion distance somewhat tapered and ISOMAP has a sharp corner —
    the sharp corner is what makes an edit "snap" in and out of the target pose.
    """)
    b.code("""
    from plotly.subplots import make_subplots

    run_basis = wand.pose_graph(run).basis()
    curves = {
        "Green's function": wand.greens_distance(run_basis, control),
        "diffusion (10 steps)": wand.normalize_distance(wand.diffusion_distance(run, control, steps=10)),
        "ISOMAP": wand.normalize_distance(wand.isomap_distance(run, control)),
    }
    frames = np.arange(run.num_frames)
    zoom = slice(control - 10, control + 11)
    fig = make_subplots(rows=1, cols=2, column_widths=[0.65, 0.35],
                        subplot_titles=("(a) whole clip", f"(b) zoom near frame {control}"))
    for (name, d), color in zip(curves.items(), px.colors.qualitative.Plotly):
        fig.add_trace(go.Scatter(x=frames, y=d, name=name, line_color=color), 1, 1)
        fig.add_trace(go.Scatter(x=frames[zoom], y=d[zoom], name=name, line_color=color, mode="lines+markers",
                                 showlegend=False), 1, 2)
    fig.update_layout(title="Fig. 3: pose distances from frame 53 of the run", height=360)
    fig.update_xaxes(title_text="frame")
    fig.show()

    # Roundness at the control frame: the rise one frame away relative to the rise two frames away.
    # A corner (|x|) gives 1/2, a rounded minimum (x^2) gives 1/4.
    def corner_ratio(d, f=control):
        return (d[f - 1] + d[f + 1]) / (d[f - 2] + d[f + 2])

    ratios = {name: round(float(corner_ratio(d)), 3) for name, d in curves.items()}
    print(ratios)
    assert ratios["Green's function"] < ratios["ISOMAP"]      # Green's is rounder than ISOMAP's corner
    assert ratios["ISOMAP"] > 0.4                             # ISOMAP is close to a sharp |x| corner
    """)
    b.md("""
    ## Figure 5 — the kernel width σ

    σ in Eq. 1 sets which poses count as neighbours. Sweeping it from half to three times the data-derived
    default (blue = smaller σ) changes the distance a lot far from the control frame, while the valley
    around the control frame stays put (the paper notes an offset of 2–3 frames at bad values). Only the
    cheap tail of the pipeline (`graph.basis(sigma)`) runs per value.
    """)
    b.code("""
    run_graph = wand.pose_graph(run)
    scales = [0.5, 0.75, 1.0, 1.5, 2.0, 3.0]
    colors = px.colors.sample_colorscale("Bluered", np.linspace(0, 1, len(scales)))
    fig = go.Figure()
    valley = {}
    for s, color in zip(scales, colors):
        sigma = s * run_graph.default_sigma
        d = wand.greens_distance(run_graph.basis(sigma), control)
        valley[s] = int(np.argmin(d[control - 8: control + 9])) + control - 8
        fig.add_trace(go.Scatter(x=frames, y=d, line_color=color, name=f"sigma = {sigma:.3f} ({s}x default)"))
    fig.add_vline(x=control, line_color="gold", line_width=6, opacity=0.6)
    fig.update_layout(title="Fig. 5: Green's distance for several kernel widths", xaxis_title="frame",
                      yaxis_title="normalised distance", height=360)
    fig.show()
    print("minimum near the control frame, per sigma scale:", valley)
    assert all(abs(f - control) <= 3 for f in valley.values())   # local information is stable (paper: 2-3 frames)
    """)
    b.md("""
    ## Figure 4 — one edit, propagated over the run cycle

    The artist edits *only* frame 20: both thighs rotate 25° forward, lifting the knees. `wand.propagate`
    takes the log-quaternion difference of the edited pose (Eq. 4) and adds it to every frame with the
    Green's falloff weight (Eq. 5). Frames where the run comes back to the same phase get almost the whole
    edit — the knees are lifted in every stride with one edit.
    """)
    b.code(SKELETON_FIGURE, """

    edit_frame = 20
    w = wand.greens_falloff(run_basis, edit_frame)
    later = frames >= 90
    similar = int(frames[later][np.argmax(w[later])])     # the most similar pose in a later stride

    edited = run.local_quats[edit_frame].copy()
    lift = rotvec_to_quat(np.radians([-25.0, 0.0, 0.0]))     # thigh forward about the hip's lateral axis
    for name in ("LeftUpLeg", "RightUpLeg"):
        j = run.skeleton.index(name)
        edited[j] = quat_mul(lift, edited[j])
    run_edited = wand.propagate(run, edit_frame, edited, basis=run_basis)

    pos0, _ = sn.forward_kinematics(run)
    pos1, _ = sn.forward_kinematics(run_edited)
    knees = [run.skeleton.index(n) for n in ("LeftLeg", "RightLeg")]
    lift_edit = pos1[edit_frame, knees, 1] - pos0[edit_frame, knees, 1]
    lift_similar = pos1[similar, knees, 1] - pos0[similar, knees, 1]
    print(f"frame {similar} has weight {w[similar]:.3f}; knee lift (cm) at frame {edit_frame}: "
          f"{np.round(lift_edit, 1)}, at frame {similar}: {np.round(lift_similar, 1)}")

    names = [f"frame {edit_frame} original", f"frame {edit_frame} edited",
             f"frame {similar} original", f"frame {similar} propagated"]
    both = np.concatenate([pos0[[edit_frame]], pos1[[edit_frame]], pos0[[similar]], pos1[[similar]]])
    both[2:, :, 2] -= pos0[similar, 0, 2] - pos0[edit_frame, 0, 2] - 120     # place the later frame beside
    skeleton_figure(both, run.skeleton.parents, range(4), colors=["lightgray", "crimson", "lightgray", "crimson"],
                    names=names, title="Fig. 4: edit at one frame (left), propagated to a similar pose (right)").show()

    assert np.allclose(run_edited.local_quats[edit_frame] * np.sign(
        np.sum(run_edited.local_quats[edit_frame] * edited, axis=-1, keepdims=True)), edited, atol=1e-9)
    assert w[similar] > 0.9 and np.all(lift_edit > 5)            # the knees really are higher at the edit
    assert np.all(lift_similar > 0.8 * lift_edit)                 # and nearly as high in the later stride
    """)
    b.md("""
    ## Figure 6 — the Green's falloff vs a generic spline falloff

    In a simple case the data-driven falloff should behave like the spline falloff an animator would draw.
    We raise the left foot at the top of its swing in one step of the walk (the left knee bends 30° more) and
    spread the edit with (a) the Green's falloff restricted to that step (`repetitions=False`) and (b) a
    generic smooth spline bump of the same width at half height, as an animator would size it to the swing.
    Plotted is the ankle's vertical channel, as in the paper. (The Green's falloff is more peaked than the
    flat-topped spline: at 30 Hz the swing lasts only about ten frames, and the pose changes fastest there.)
    """)
    b.code("""
    ankle = walk.skeleton.index("LeftFoot")
    pos_w, _ = sn.forward_kinematics(walk)
    height = pos_w[:, ankle, 1]
    step_range = (40, 80)
    top = int(np.argmax(height[step_range[0]:step_range[1]])) + step_range[0]   # top of the swing

    edited = walk.local_quats[top].copy()
    knee = walk.skeleton.index("LeftLeg")
    edited[knee] = quat_mul(rotvec_to_quat(np.radians([30.0, 0.0, 0.0])), edited[knee])

    w_green = wand.greens_falloff(walk_basis, top, frame_range=step_range, repetitions=False)

    def half_width(w, step):
        '''Frames from `top` until the falloff w drops below one half, going by `step` (+1 / -1).'''
        j = top
        while 0 <= j + step < len(w) and w[j + step] >= 0.5:
            j += step
        return abs(j - top) + 0.5

    # the animator's spline: a smoothstep bump with the same width at half height as the Green's falloff
    extent = (2 * half_width(w_green, -1), 2 * half_width(w_green, +1))
    w_spline = wand.spline_falloff(walk.num_frames, top, extent=extent)

    ref = wand.mean_rotations(walk.local_quats)          # the log map is taken about the mean pose
    logs = wand.pose_logs(walk.local_quats, ref)
    delta = wand.pose_logs(edited, ref) - logs[top]                       # Eq. 4
    def apply(weights):                                                   # Eq. 5 with the given falloff
        new = wand.pose_exps(wand.propagate_logs(logs, np.array([top]), delta[None], weights[None]), ref)
        return sn.forward_kinematics(walk.replace(local_quats=new))[0][:, ankle, 1]

    h_spline, h_green = apply(w_spline), apply(w_green)
    t = np.arange(walk.num_frames)
    window = slice(step_range[0] - 10, step_range[1] + 10)
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, row_heights=[0.65, 0.35],
                        subplot_titles=("left ankle height (cm)", "falloff weight"))
    fig.add_trace(go.Scatter(x=t[window], y=height[window], name="original", line_color="gray"), 1, 1)
    fig.add_trace(go.Scatter(x=t[window], y=h_spline[window], name="spline falloff edit"), 1, 1)
    fig.add_trace(go.Scatter(x=t[window], y=h_green[window], name="Green's falloff edit"), 1, 1)
    fig.add_trace(go.Scatter(x=t[window], y=w_spline[window], name="spline weight", showlegend=False,
                             line_color=px.colors.qualitative.Plotly[1]), 2, 1)
    fig.add_trace(go.Scatter(x=t[window], y=w_green[window], name="Green's weight", showlegend=False,
                             line_color=px.colors.qualitative.Plotly[2]), 2, 1)
    fig.update_layout(title=f"Fig. 6: raising the foot at frame {top}, spline vs Green's falloff", height=460)
    fig.show()

    raise_spline, raise_green = h_spline[top] - height[top], h_green[top] - height[top]
    print(f"foot raised at frame {top}: spline {raise_spline:.1f} cm, Green's {raise_green:.1f} cm")
    assert np.isclose(raise_spline, raise_green)          # both apply the full edit at the edited frame
    outside = np.r_[0:step_range[0], step_range[1]:walk.num_frames]
    assert np.allclose(h_green[outside], height[outside])  # and nothing outside the chosen step
    # similar shapes: the two edits differ much less than either differs from the original
    assert np.abs(h_green - h_spline).max() < 0.5 * np.abs(h_green - height).max()
    """)
    b.md("""
    ## The magic-wand editor

    Pick the edited frame and a joint, rotate it with the sliders, and watch the edit spread: the 3D view
    shows the result over the original ghost, the plot shows the falloff (with ISOMAP, diffusion and spline
    curves for comparison). The σ slider snaps to values whose eigenbases are precomputed in the background;
    the frame range and "repetitions" decide how far the edit may travel.
    """)
    b.code("""
    from stagger_nb.widgets import WandEditor
    editor = WandEditor(run, frame=edit_frame, joint="LeftUpLeg")
    editor
    """)
    return b


def timewarp_nb() -> Book:
    b = Book("03_guided_time_warping")
    b.md("""
    # Guided time warping (Hsu, da Silva & Popović 2007)

    A time warp changes *when* poses happen, never the poses. Given keytimes (at least a new duration) and a
    *reference motion*, guided time warping picks a subsequence of input frames — complete (first and last
    frame kept, no gap larger than `skip` frames) and monotonic (§3.1) — whose local velocities and
    accelerations look most like the reference's (the k-nearest-neighbour score of Eq. 2, §3.2). The best
    subsequence is found exactly by a constrained shortest-path dynamic programme (Eqs. 3–4, §3.3); the
    discrete warp is then smoothed and the motion resampled with slerp (§3.4). Expansions are compressions of
    an upsampled input.

    ```python
    out, warp = timewarp.guided_warp(m, reference, num_frames, skip=8, keytimes=None)
    out, warp = timewarp.linear_warp(m, num_frames)      # the spline-style baseline
    # warp: (num_frames,) input time in seconds of every output frame
    ```

    As in the paper everything runs at 30 Hz.
    """)
    b.code("""
    import time

    import numpy as np
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots
    from tqdm.auto import tqdm

    import stagger_nb as sn
    from stagger_nb import timewarp

    cmu = sn.data.load("cmu_01_01").resample(1 / 30)      # real capture: forward jumps, turn, jumps back
    walk = sn.data.load("walk").resample(1 / 30)
    ft = cmu.frame_time
    n = cmu.num_frames
    print(f"CMU 01_01: {n} frames ({cmu.duration:.1f} s); walk: {walk.num_frames} frames")


    def airborne(m, clearance=8.0):
        '''(F,) bool: both toes more than `clearance` cm above the clip's ground level.'''
        pos, _ = sn.forward_kinematics(m)
        toes = [m.skeleton.index(j) for j in ("LeftToeBase", "RightToeBase")]
        h = pos[:, toes, 1].min(axis=1)
        return h > np.percentile(h, 5) + clearance


    def at_input(mask, m, warp):
        '''Sample a per-input-frame mask at the input times `warp` of the output frames.'''
        return mask[np.clip(np.round(warp / m.frame_time).astype(int), 0, m.num_frames - 1)]


    def manual_warp(m, speed):
        '''A hand-made warp: play input frame f at `speed[f]` times real time; input seconds per output frame.'''
        t = [0.0]
        while t[-1] < m.duration - 1e-9:
            f = min(int(round(t[-1] / m.frame_time)), m.num_frames - 1)
            t.append(min(t[-1] + speed[f] * m.frame_time, m.duration))
        return np.array(t)


    air = airborne(cmu)
    print("airborne input frames:", int(air.sum()), "in", int(np.sum(np.diff(air.astype(int)) == 1)), "jumps")
    """)
    b.md("""
    ## §4.1 Preservation — shorten and lengthen, using the motion as its own reference

    A linear warp (what a two-keytime spline warp does) speeds every part up equally, so the jumps become
    implausibly quick. With the input as its own reference, guided warping speeds through the walking and
    standing and keeps the jumps close to their real timing. Below: the warp curves (input time of every
    output frame) with the flight phases marked, and the local speed inside and outside the flights.
    """)
    b.code("""
    results = {}
    for label, frac in tqdm([("compress to 65 %", 0.65), ("expand to 150 %", 1.5)], desc="warping"):
        m_out = int(round(frac * (n - 1))) + 1
        guided, g_warp = timewarp.guided_warp(cmu, cmu, m_out)
        linear, l_warp = timewarp.linear_warp(cmu, m_out)
        results[label] = dict(m=m_out, guided=(guided, g_warp), linear=(linear, l_warp))

    fig = make_subplots(rows=1, cols=2, subplot_titles=list(results))
    for col, (label, r) in enumerate(results.items(), start=1):
        out_t = np.arange(r["m"]) * ft
        for name, (_, warp) in (("linear", r["linear"]), ("guided", r["guided"])):
            fig.add_trace(go.Scatter(x=out_t, y=warp, name=name, showlegend=col == 1,
                                     line_color="gray" if name == "linear" else "crimson"), 1, col)
        g_warp = r["guided"][1]
        in_air = at_input(air, cmu, g_warp)
        fig.add_trace(go.Scatter(x=out_t[in_air], y=g_warp[in_air], mode="markers", marker_size=4,
                                 marker_color="royalblue", name="airborne (guided)", showlegend=col == 1), 1, col)
        fig.update_xaxes(title_text="output time (s)", row=1, col=col)
    fig.update_yaxes(title_text="input time (s)", row=1, col=1)
    fig.update_layout(title="Guided vs linear warps of CMU 01_01 (self-reference)", height=380)
    fig.show()

    rows = []
    for label, r in results.items():
        for name in ("linear", "guided"):
            _, warp = r[name]
            speed = timewarp.warp_speed(warp, ft)
            in_air = at_input(air, cmu, warp)
            rows.append((label, name, speed[in_air].mean(), speed[~in_air].mean()))
            print(f"{label:17s} {name:7s} speed in the air {rows[-1][2]:.2f}x, on the ground {rows[-1][3]:.2f}x")

    for label, r in results.items():
        lin_air = [row[2] for row in rows if row[:2] == (label, "linear")][0]
        gui_air = [row[2] for row in rows if row[:2] == (label, "guided")][0]
        # the jumps stay much closer to real time (speed 1) than under the linear warp
        assert abs(gui_air - 1) < 0.5 * abs(lin_air - 1), (label, gui_air, lin_air)
    """)
    b.md("""
    Plotted against output time, the root height shows what the numbers say: under the linear compression
    every jump is squeezed; the guided warp keeps each flight's duration and spends the saved time elsewhere.
    """)
    b.code("""
    guided, g_warp = results["compress to 65 %"]["guided"]
    linear, l_warp = results["compress to 65 %"]["linear"]
    fig = go.Figure()
    fig.add_trace(go.Scatter(x=cmu.times, y=cmu.root_positions[:, 1], name=f"input ({cmu.duration:.1f} s)",
                             line_color="lightgray"))
    fig.add_trace(go.Scatter(x=linear.times, y=linear.root_positions[:, 1], name="linear", line_color="gray"))
    fig.add_trace(go.Scatter(x=guided.times, y=guided.root_positions[:, 1], name="guided", line_color="crimson"))
    fig.update_layout(title="Root height: input, linear and guided compression to 65 %", xaxis_title="time (s)",
                      yaxis_title="root height (cm)", height=330)
    fig.show()
    assert guided.num_frames == linear.num_frames == results["compress to 65 %"]["m"]
    """)
    b.md("""
    ## §4.2 Modification — slow-motion jumps from one hand-made example (V8)

    The reference no longer has to be the input. Here an animator has slowed *one* jump down by hand (flight
    at 0.4× speed) — a 35-frame clip. Used as the reference for the whole capture, with the output length
    set to leave room for the slow motion, guided warping finds every other jump and slows it down the same
    way, although the jumps differ from the example, while the rest keeps playing at about real time.
    """)
    b.code("""
    example = cmu.slice(95, 130)                              # one jump, 35 frames
    slow_mo = timewarp.apply_warp(example, manual_warp(example, np.where(air[95:130], 0.4, 1.0)), adaptive=False)
    m_slow = n + int(1.5 * air.sum())
    out_slow, warp_slow = timewarp.guided_warp(cmu, slow_mo, m_slow)
    speed_slow = timewarp.warp_speed(warp_slow, ft)
    in_air = at_input(air, cmu, warp_slow)
    print(f"reference: {example.num_frames} -> {slow_mo.num_frames} frames; output {m_slow} frames; "
          f"speed in the air {speed_slow[in_air].mean():.2f}x, on the ground {speed_slow[~in_air].mean():.2f}x")
    assert speed_slow[in_air].mean() < 0.6               # the flights are in slow motion (example: 0.4x)
    assert 0.8 < speed_slow[~in_air].mean() < 1.25       # the rest stays near real time
    """)
    b.md("""
    ## §4.2 Modification — propagate a hand-edited limp (V7)

    One stride of the walk is retimed by hand to look like a limp: the left single-support phase plays at
    half speed, so the character lingers on the left leg. That 45-frame stride is the only reference; the
    guided warp gives the same timing to every stride of the walk. We count output frames in left and right
    single support: their ratio is about 1 in the walk and about 2 in the hand-edited stride.
    """)
    b.code("""
    def single_support(m, tol=2.0):
        '''(F,) bool pair: only the left / only the right ankle is within `tol` cm of its lowest height.'''
        pos, _ = sn.forward_kinematics(m)
        h = pos[:, [m.skeleton.index("LeftFoot"), m.skeleton.index("RightFoot")], 1]
        low = h < h.min(axis=0) + tol
        return low[:, 0] & ~low[:, 1], low[:, 1] & ~low[:, 0]

    left, right = single_support(walk)
    start = int(np.flatnonzero(np.diff(left.astype(int)) == 1)[0]) + 1     # first left foot-down
    period = int(np.flatnonzero(np.diff(left.astype(int)) == 1)[1]) + 1 - start
    stride = walk.slice(start, start + period + 1)
    limp = timewarp.apply_warp(stride, manual_warp(stride, np.where(left[start:start + period + 1], 0.5, 1.0)),
                               adaptive=False)
    m_limp = int(round((walk.num_frames - 1) * (limp.num_frames - 1) / (stride.num_frames - 1))) + 1
    out_limp, warp_limp = timewarp.guided_warp(walk, limp, m_limp)
    lin_limp, _ = timewarp.linear_warp(walk, m_limp)

    def lr_ratio(m):
        l, r = single_support(m)
        return l.sum() / r.sum()

    ratios = {"walk": lr_ratio(walk), "hand-edited stride": lr_ratio(limp), "linear warp": lr_ratio(lin_limp),
              "guided warp": lr_ratio(out_limp)}
    print({k: round(float(v), 2) for k, v in ratios.items()})
    l_out, r_out = single_support(out_limp)
    print("".join("L" if a else ("R" if b else "·") for a, b in zip(l_out, r_out)))
    assert ratios["hand-edited stride"] > 1.6 * ratios["walk"]           # the hand edit is a clear limp
    assert ratios["guided warp"] > 0.8 * ratios["hand-edited stride"]   # the limp reaches every stride
    assert abs(ratios["linear warp"] - ratios["walk"]) < 0.25            # a linear warp cannot do that
    """)
    b.md("""
    ## Figure 5 — warp derivatives on a log scale

    The local speed of each warp (input seconds per output second). The centre line is real time; the limits
    are tenfold slow motion and tenfold fast forward. Linear warps are flat lines; guided warps speed up and
    slow down where the reference says so.
    """)
    b.code("""
    warps = {
        "compress 65 % (V4)": results["compress to 65 %"]["guided"][1],
        "expand 150 % (V5)": results["expand to 150 %"]["guided"][1],
        "slow-motion jumps (V8)": warp_slow,
        "limp (V7)": warp_limp,
    }
    fig = make_subplots(rows=len(warps), cols=1, subplot_titles=list(warps), vertical_spacing=0.1)
    for row, (name, warp) in enumerate(warps.items(), start=1):
        speed = timewarp.warp_speed(warp, ft)
        t_out = np.arange(len(warp)) * ft
        fig.add_trace(go.Scatter(x=t_out, y=speed, line_color="crimson", showlegend=False), row, 1)
        fig.add_hline(y=1, line_color="gray", line_width=1, row=row, col=1)
        fig.update_yaxes(type="log", range=[-1, 1], tickvals=[0.1, 1, 10], row=row, col=1)
        assert np.all(speed > 0)                       # monotonic: time never stops or reverses
        assert speed.max() <= 8 + 1e-9                 # the skip limit s = 8 bounds the speed
    fig.update_xaxes(title_text="output time (s)", row=len(warps), col=1)
    fig.update_layout(title="Fig. 5: derivatives of the time warps (log scale)", height=820)
    fig.show()
    """)
    b.md("""
    ## Table 1 — parameters and running times, measured now

    `n`, `m`, `r`: frame counts of the searched input (after upsampling for expansions), output and reference;
    `s`: the skip limit. *Objective*: features and the kNN score table (`prepare_warp`); *optimization*: the
    exact constrained dynamic programme (`solve_warp`); *heuristic*: the coarse-to-fine search that first
    solves at 1/8 resolution (§3.3). The paper's times are from a 2.4 GHz Pentium 4 with C++ and MATLAB;
    these are numpy on this machine.
    """)
    b.code("""
    trials = [("V4-like: compress CMU", cmu, cmu, results["compress to 65 %"]["m"]),
              ("V5-like: expand CMU", cmu, cmu, results["expand to 150 %"]["m"]),
              ("V7: limp", walk, limp, m_limp),
              ("V8: slow-motion jumps", cmu, slow_mo, m_slow)]
    table = []
    for name, m_in, ref, m_out in tqdm(trials, desc="Table 1"):
        t0 = time.perf_counter()
        tables = timewarp.prepare_warp(m_in, ref, skip=8, upsample=timewarp.required_upsample(m_in.num_frames, m_out))
        t1 = time.perf_counter()
        exact = timewarp.solve_warp(tables, m_out)
        t2 = time.perf_counter()
        fast = timewarp.solve_warp(tables, m_out, coarse=8)
        t3 = time.perf_counter()
        table.append((name, tables.X.shape[0], m_out, tables.R.shape[0], tables.skip, t1 - t0, t2 - t1, t3 - t2,
                      exact.cost, fast.cost))

    fig = go.Figure(go.Table(
        header=dict(values=["trial", "n", "m", "r", "s", "objective", "optimization", "heuristic",
                            "heuristic / exact cost"]),
        cells=dict(values=list(zip(*[(name, nn, mm, rr, ss, f"{a:.2f} s", f"{b:.2f} s", f"{c:.2f} s",
                                      f"{fc / ec:.4f}") for name, nn, mm, rr, ss, a, b, c, ec, fc in table])))))
    fig.update_layout(title="Table 1 (measured live)", height=360, margin=dict(t=40, b=0))
    fig.show()
    for row in table:
        print("{:24s} n={:4d} m={:4d} r={:3d} s={}  objective {:.2f} s  optimization {:.2f} s  heuristic {:.2f} s"
              .format(*row[:8]))
    for row in table:
        name, ec, fc = row[0], row[8], row[9]
        assert ec <= fc * (1 + 1e-6)          # the exact DP is optimal: the heuristic can only tie or lose
        assert fc <= 1.1 * ec, (name, fc / ec)  # and the heuristic loses little (paper: "minimal degradation")
    """)
    b.md("""
    ## The time-warping editor

    Set the target duration, the skip limit and keytimes, choose the reference — the input itself, a segment
    of it, or the hand-edited limp stride from above — and compare guided with linear warping. The plots
    show the warp curve and its derivative on the log scale of Fig. 5; the 3D view plays the result over the
    original ghost.
    """)
    b.code("""
    from stagger_nb.widgets import WarpEditor
    editor = WarpEditor(walk, reference={"limp stride": limp})
    editor
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
