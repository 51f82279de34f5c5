# ---
# jupyter:
#   jupytext:
#     notebook_metadata_filter: -jupytext.text_representation.jupytext_version
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3 (ipykernel)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # stagger_nb quickstart
#
# **stagger_nb** edits skeletal motion capture (BVH) in Jupyter with three techniques from the literature:
#
# | technique | paper | what you control |
# |---|---|---|
# | staggered poses | Coleman, Bibliowicz, Singh & Gleicher 2008 | a few extreme poses and the *timing* among body parts |
# | magic wand | Dean, Lewis & Chalmers 2018 | one edited frame; the data decides how far the edit reaches |
# | guided time warping | Hsu, da Silva & Popović 2007 | the duration; a reference motion decides the timing |
#
# This notebook takes one clip through all of it in a few cells: load, look, one edit with each technique,
# export a BVH file and save the edit session. The other notebooks (01, 02, 03) walk through each paper.
#
# Conventions: times are seconds, frame ranges are half-open, quaternions are `(x, y, z, w)`.

# %%
import shutil
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

# %% [markdown]
# ## Any BVH file
#
# `sn.read_bvh(path)` reads any BVH file into a frozen `Motion`; `sn.write_bvh(motion, path)` writes one.
# Here we read the CMU sample clip by its path. (Replace the path with your own file.)

# %%
path = sn.data.path("cmu_01_01")       # or any other .bvh path on your machine
cmu = sn.read_bvh(path)
print(path.name, cmu.num_frames, "frames,", round(cmu.duration, 2), "s,", cmu.skeleton.num_joints, "joints")
assert cmu.num_frames > 100 and cmu.frame_time > 0


# %% [markdown]
# ## Look at it
#
# Forward kinematics turns the joint rotations into world positions, `(F, J, 3)`. A static strobe of a few
# frames is a plotly figure; the interactive `SkeletonView` plays the clip in 3D (drag to orbit, the slider
# scrubs time).

# %%
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

positions, world_quats = sn.forward_kinematics(walk)
frames = np.linspace(0, walk.num_frames - 1, 6).astype(int)
skeleton_figure(positions, walk.skeleton.parents, frames, title="walk: six frames").show()

# %%
from stagger_nb.widgets import SkeletonView
SkeletonView(walk)

# %% [markdown]
# ## One edit with each technique, recorded in a session
#
# A `Session` is the source motion plus an ordered list of JSON operations; replaying them gives the
# edited motion, so every edit is reproducible, undoable and saveable. The same operations are plain
# functions in `staggered`, `wand` and `timewarp` (notebooks 01–03 use them directly).
#
# **Staggered poses** — nonlinear succession down the left arm: the hand's extremes now trail the
# shoulder's by $s\,d^l$ seconds ($d$ = bones from the shoulder).

# %%
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

# %% [markdown]
# **Magic wand** — rotate the left upper arm by 25° at one frame; the Green's-function falloff carries the
# edit to every similar pose of the walk.

# %%
frame = 120
session.add({"op": "propagate", "frame": frame, "deltas": {"LeftArm": [0.0, 0.0, -25.0]}})
step2 = session.edited()
weight = wand.falloff(step1, frame)
arm = walk.skeleton.index("LeftArm")
change = np.degrees(quat_angle(step2.local_quats[:, arm], step1.local_quats[:, arm]))
print(f"change at the edited frame {change[frame]:.1f} deg; frames with weight > 0.9: {np.sum(weight > 0.9)}")
assert abs(change[frame] - 25.0) < 1e-6          # the edited frame gets the whole edit
assert np.sum(weight > 0.9) > 3 * np.sum(np.abs(np.arange(walk.num_frames) - frame) <= 2)   # non-local

# %% [markdown]
# **Guided time warping** — make the clip 25 % shorter, with the motion as its own timing reference.

# %%
session.add({"op": "guided_warp", "duration": 0.75 * walk.duration})
result = session.edited()
warp = session.warp_curve()
print(f"{walk.duration:.2f} s -> {result.duration:.2f} s; warp from {warp[0]:.2f} s to {warp[-1]:.2f} s")
assert abs(result.duration - 0.75 * walk.duration) <= walk.frame_time
assert np.all(np.diff(warp) > 0) and np.isclose(warp[-1], walk.duration)   # monotonic and complete
print(session.ops)

# %% [markdown]
# ## Export and save
#
# `export_bvh` writes the edited motion (it refuses to overwrite the source file); `save` writes the session
# as JSON — the source by path and checksum, plus the op list. Loading and replaying gives the same motion.

# %%
out_dir = Path(tempfile.mkdtemp(prefix="stagger_nb_quickstart_"))
session.export_bvh(out_dir / "walk_edited.bvh")
session.save(out_dir / "walk_edited.session.json")

back = sn.read_bvh(out_dir / "walk_edited.bvh")
replayed = Session.load(out_dir / "walk_edited.session.json").edited()
print(sorted(p.name for p in out_dir.iterdir()))
assert back.num_frames == result.num_frames
assert np.allclose(sn.forward_kinematics(back)[0], sn.forward_kinematics(result)[0], atol=1e-3)  # BVH text: 6 decimals
assert np.allclose(replayed.local_quats, result.local_quats)
shutil.rmtree(out_dir)   # a scratch folder: nothing is left behind in notebooks/

# %% [markdown]
# ## Interactive editing
#
# Each technique has an editor with sliders, the 3D view (the original as a grey ghost) and its plots; it
# edits the same kind of session, so what you do there can be saved and replayed the same way. Notebooks
# 01–03 end with `StaggerEditor`, `WandEditor` and `WarpEditor`; here is the staggered-pose editor on the
# session above (drag the sliders, then `editor.session.save(...)`).

# %%
from stagger_nb.widgets import StaggerEditor
editor = StaggerEditor(session)
editor
