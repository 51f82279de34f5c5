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
# | staggered poses | Coleman, Bibliowicz, Singh & Gleicher 2008 | a few extreme poses, the *timing* among body parts |
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

import stagger_nb as sn
from stagger_nb import plotting, staggered, wand
from stagger_nb.core.rotations import quat_angle

walk = sn.data.load("walk")            # a sample clip from data/ (made by `make lab` / `make test`)
print(walk.num_frames, "frames at", round(1 / walk.frame_time), "Hz;", walk.skeleton.num_joints, "joints")
print(walk.skeleton.names)

# %% [markdown]
# ## Any BVH file
#
# `sn.read_bvh(path)` reads any BVH file into a frozen `Motion`; `sn.write_bvh(motion, path)` writes one.
# Here we read the CMU sample clip by its path. (Replace the path with your own file.) The set-up step also
# prepares two more real captures, `mocapbank_get_down` and `freebvh_step` (`sn.data.REAL`; provenance and
# terms in `data/README.md`); `walk`, `run`, `jump` are procedural teaching aids.

# %%
path = sn.data.path("cmu_01_01")       # or any other .bvh path on your machine
cmu = sn.read_bvh(path)
print(path.name, cmu.num_frames, "frames,", round(cmu.duration, 2), "s,", cmu.skeleton.num_joints, "joints")
for name in sn.data.REAL[1:]:
    m = sn.data.load(name)
    print(name, m.num_frames, "frames,", round(m.duration, 2), "s,", m.skeleton.num_joints, "joints")


# %% [markdown]
# ## Look at it
#
# Forward kinematics turns the joint rotations into world positions, `(F, J, 3)`. A static strobe of a few
# frames is a plotly figure; the interactive `SkeletonView` plays the clip in 3D (drag to orbit, the slider
# scrubs time).

# %%
from stagger_nb.widgets import PlotView

positions, world_quats = sn.forward_kinematics(walk)          # (F, J, 3) cm, (F, J, 4)
frames = np.linspace(0, walk.num_frames - 1, 6).astype(int)
PlotView(plotting.skeleton_strobe_figure(positions, walk.skeleton.parents, frames, title="walk: six frames"),
         show_playhead=False)   # a figure drawn by the page itself (offline), as the editors draw theirs

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
assert np.sum(weight > 0.9) > 3 * np.sum(np.abs(np.arange(walk.num_frames) - frame) <= 2)   # non-local

# %% [markdown]
# **Guided time warping** — make the clip 25 % shorter, with the motion as its own timing reference.

# %%
session.add({"op": "guided_warp", "duration": 0.75 * walk.duration})
result = session.edited()
warp = session.warp_curve()
print(f"{walk.duration:.2f} s -> {result.duration:.2f} s; warp from {warp[0]:.2f} s to {warp[-1]:.2f} s")
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
