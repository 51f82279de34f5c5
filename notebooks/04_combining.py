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
# # One edit, three papers: the wand selects, the staggered poses edit, the guided warp times
#
# Each of the first three tutorials reproduces one paper. None of the papers shows what they give together,
# and each is a piece the others lack:
#
# * the **magic wand** (Dean et al. 2018) finds every pose *similar* to an edited one (its Green's-function
#   falloff, §3.3) but edits frames, so a change of one step smears over the frames around it;
# * the **staggered poses** (Coleman et al. 2008) edit a few *poses* and keep the timing between body parts
#   (the refinements) and the detail (the displacement maps) — one pose at a time (§5.1, §5.2);
# * **guided time warping** (Hsu et al. 2007) times a whole motion like a reference, but warps frames: the
#   staggering and the edits on top of it cannot be changed afterwards.
#
# Three ops of an edit session combine them; each is one JSON line, so the session replays them exactly:
#
# ```python
# {"op": "edit_pose", "pose": k, "deltas": {...}, "propagate": True, "sigma": None}   # also exaggerate, ik_pose
# {"op": "succession", "root": "LeftShoulder", "s": 0.01, "falloff": {"frame": f, "sigma": None}}  # random_timing
# {"op": "guide_poses", "reference": {"path": "slow.bvh"}, "keytimes": None}
# ```
#
# Clips: the procedural walk (a teaching aid: its steps are exactly alike) and the real hops of CMU 01_01
# (hops, a stop, a turn-around, hops back).

# %%
# set-up: the clips, their sessions, and the gait marks the checks read (where each step is at the same phase)
import json
import tempfile
from pathlib import Path

import numpy as np
import plotly.io as pio
from scipy.signal import find_peaks

import stagger_nb as sn
from stagger_nb import plotting, staggered, timewarp
from stagger_nb.core.rotations import quat_angle
from stagger_nb.session import Session

walk = sn.data.load("walk")                                 # procedural teaching aid, 60 Hz, 5.5 gait cycles
hops = sn.data.load("cmu_01_01")                            # real capture, 120 Hz
ARM = "LeftArm"


def step_marks(m):
    """Frames where the left foot is farthest ahead (the same phase of each gait cycle) and the right foot
    is (the opposite phase): peaks of the feet's separation along the walk's direction (+z here)."""
    p = sn.forward_kinematics(m)[0]
    s = p[:, m.skeleton.index("LeftFoot"), 2] - p[:, m.skeleton.index("RightFoot"), 2]
    return find_peaks(s, prominence=0.4 * np.ptp(s))[0], find_peaks(-s, prominence=0.4 * np.ptp(s))[0]


def hop_marks(m):
    """Flight apexes (the pelvis 10 cm above its median height) and the frames half-way between two apexes."""
    y = m.root_positions[:, 1]
    top = find_peaks(y, prominence=10.0)[0]
    top = top[y[top] > np.median(y) + 10.0]
    gap = np.diff(top)
    return top, ((top[:-1] + top[1:]) // 2)[gap <= 1.5 * np.median(gap)]


def moved(session, joint=ARM):
    """Share of a 20° edit by which `joint`'s local rotation moved, frame by frame (F,)."""
    j = session.source.skeleton.index(joint)
    before = staggered.evaluate(session.extraction()).local_quats[:, j]
    return np.degrees(quat_angle(before, session.edited().local_quats[:, j])) / 20.0


walk_session, hop_session = Session(walk), Session(hops)
same, opposite = step_marks(walk)
print(f"walk: {walk_session.extraction().num_poses} poses, steps at frames {same} (same phase), {opposite} (opposite)")

# %% [markdown]
# ## 1. One nudge of one step changes every step (Dean §3.3 on Coleman §5.1)
#
# We rotate the left upper arm by 20° at the staggered pose of one step. With `"propagate": true` the same
# offset reaches every pose `j` weighted by the wand's falloff of the edited pose, read at pose `j`'s time:
# `v̂_j = v_j ⊕ exp(w_j log δ)`, in pose `j`'s own knots — its refinements and displacement maps are kept, so
# each step keeps its timing and its detail.
#
# **Check:** the arm moves by at least 0.8 of the edit at the same phase of every other step, by at most 0.2
# at the opposite phase, and the refinements (the staggering) do not change.
# **Look at** the line (how much of the edit each frame got) against the diamonds (the falloff at each pose).

# %%
sm = walk_session.extraction()
k = int(np.argmin(np.abs(sm.pose_times / walk.frame_time - same[2])))          # the pose of the third step
walk_session.set_ops([{"op": "edit_pose", "pose": k, "deltas": {ARM: [0.0, 0.0, 20.0]}, "propagate": True}])
share, w = moved(walk_session), walk_session.pose_falloff(int(round(sm.pose_times[k] / walk.frame_time)))
pio.show(plotting.lines_figure({"share of the edit": (walk.times, share)}, vlines=sm.pose_times,
                               highlight={"falloff at the poses": (sm.pose_times, w),
                                          "same phase": (walk.times[same], share[same]),
                                          "opposite phase": (walk.times[opposite], share[opposite])},
                               y_title="share of the 20° edit", title="walk: one edited step, every step moved"))

# %%
others = [f for f in same if abs(f - same[2]) > 10]
print(f"same phase {np.round(share[others], 2)}, opposite {np.round(share[opposite], 2)}")
assert share[others].min() >= 0.8 and share[opposite].max() <= 0.2
assert np.array_equal(walk_session.staggered().refinements, sm.refinements)

# %% [markdown]
# Without propagation the staggered edit stays between the neighbouring poses (§5.1: the plateau and its
# ramps), so the other steps keep the old arm: **check** that they do not move at all.

# %%
walk_session.set_ops([{"op": "edit_pose", "pose": k, "deltas": {ARM: [0.0, 0.0, 20.0]}}])
alone = moved(walk_session)
print(f"without propagate: same phase {np.round(alone[others], 3)}")
assert alone[others].max() < 1e-6 and alone[same[2]] > 0.8

# %% [markdown]
# ### On real hops: the region decides
#
# CMU 01_01 is not a loop: between the forward hops and the hops back the performer stops and turns around,
# the least similar frames of the clip, where the falloff's 0 lies (§3.3: 0 "at the most dissimilar pose in
# the region"). The ground phases between hops then keep about a quarter of the similarity, and half-way
# between two apexes the arm moves by 0.4–0.55 of the edit. Dean's answer is the artist's: choose the region
# and σ ("the artist selects the region of the motion to edit", §3.3; "σ should be adjusted by the artist",
# §4.2).
#
# **Check:** restricting the falloff to the hops back (`frame_range`) with twice the default σ brings the
# opposite phase below 0.2 of the edit. **Look at** the apexes: some keep less than 0.8 of it (the printed
# line) — the price of the sharper falloff, and the reason the default stays Dean's.

# %%
top, between = hop_marks(hops)
hk = int(np.argmin(np.abs(hop_session.extraction().pose_times / hops.frame_time - top[-3])))  # an apex of the hops back
edit = {"op": "edit_pose", "pose": hk, "deltas": {ARM: [0.0, 0.0, 20.0]}, "propagate": True}
hop_session.set_ops([edit])
plain = moved(hop_session)
region = dict(edit, frame_range=[1100, hops.num_frames], sigma=2 * hop_session.wand_graph().default_sigma)
hop_session.set_ops([region])
chosen, back = moved(hop_session), between[between >= 1100]
print(f"half-way between apexes: defaults {np.round(plain[back], 2)}, region and 2σ {np.round(chosen[back], 2)}")
apex = top[top >= 1100]
print(f"apexes of the hops back: defaults {np.round(plain[apex], 2)}, region {np.round(chosen[apex], 2)}")
assert chosen[back].max() <= 0.2 < plain[back].max()

# %%
pio.show(plotting.lines_figure({"defaults": (hops.times, plain), "region and 2σ": (hops.times, chosen)},
                               highlight={"apexes": (hops.times[top], chosen[top])},
                               vlines=hops.times[back], y_title="share of the 20° edit",
                               title="CMU 01_01: one hop's arm edit propagated (dotted: half-way between apexes)"))

# %% [markdown]
# ## 2. A timing edit in a magic-wand region (Dean §3.3 on Coleman §5.2)
#
# "Make this punch lag" should make this punch and the similar ones lag, and leave the rest of the clip's
# timing alone. `"falloff": {"frame": f, "sigma": σ}` on a succession (or a random timing) scales each
# pose's offsets `s d(i)^l` by the falloff around frame `f` read at the pose's time, before the timing
# saturation keeps every joint's knots in order. Where the region's edge squeezes a segment (a pose of weight 1
# next to one of weight 0.1), the saturation gives way on the side of the lower weight: the poses the region
# selects keep their delay, the transition moves outward.
#
# **Check:** where the falloff is at least 0.9 the refinements change by at least 0.8 of what the same
# succession changes them without the region, and by at most 0.1 of it where the falloff is at most 0.05.

# %%
frame = int(round(sm.pose_times[k] / walk.frame_time))
succession = {"op": "succession", "root": "LeftShoulder", "s": 0.01, "l": 1.0}
walk_session.set_ops([succession])
unscaled = walk_session.staggered().refinements - sm.refinements
walk_session.set_ops([dict(succession, falloff={"frame": frame, "sigma": None})])
scaled, w = walk_session.staggered().refinements - sm.refinements, walk_session.pose_falloff(frame)
hand = walk.skeleton.index("LeftHand")
ratio = np.divide(scaled[:, hand], unscaled[:, hand], out=np.zeros(sm.num_poses), where=unscaled[:, hand] != 0)
print(np.round(np.c_[w, ratio], 2).T)
assert np.all(ratio[(w >= 0.9) & (unscaled[:, hand] != 0)] >= 0.8) and np.all(np.abs(ratio[w <= 0.05]) <= 0.1)

# %%
pio.show(plotting.lines_figure({"falloff at the poses": (sm.pose_times, w)},
                               highlight={"hand's delay / the delay without the region": (sm.pose_times, ratio)},
                               vlines=sm.pose_times, y_title="weight", title="walk: a succession in a region"))

# %% [markdown]
# ## 3. Staggered poses timed like a reference (Hsu §3 on Coleman §5.2)
#
# `guide_poses` computes the guided warp of the source to a reference and maps every pose time through it;
# the refinements, splines and displacement maps follow the poses (Coleman §5.2: retiming poses "as a unit").
# Unlike a `guided_warp` of the edited motion, the staggered edits stay editable after it: a succession added
# later still shifts the refined knots, now on the reference's rhythm.
#
# Reference: the walk played 1.5× slower (a clip written to a file, as a session stores it).
# **Check:** every two consecutive poses are 1.5 ± 0.15× as far apart as before, every refinement stays
# within 1 ms, and a succession after the retiming adds exactly what it adds on its own.

# %%
folder = Path(tempfile.mkdtemp())
slow = timewarp.linear_warp(walk, int(round((walk.num_frames - 1) * 1.5)) + 1)[0]
sn.write_bvh(slow, folder / "slow_walk.bvh")
walk_session.set_ops([{"op": "guide_poses", "reference": {"path": str(folder / "slow_walk.bvh")}}])
guided = walk_session.staggered()
spacing = np.diff(guided.pose_times) / np.diff(sm.pose_times)
print(f"pose spacing ratios {np.round(spacing.min(), 3)}..{np.round(spacing.max(), 3)}, "
      f"refinements moved by {np.abs(guided.refinements - sm.refinements).max() * 1e3:.3f} ms")
assert np.all(np.abs(spacing - 1.5) <= 0.15) and np.abs(guided.refinements - sm.refinements).max() <= 1e-3

# %%
warp = walk_session.warp_curve(0)
out_t = np.arange(warp.size) * walk.frame_time
pio.show(plotting.warp_figure(out_t, warp, timewarp.warp_speed(warp, walk.frame_time),
                              title="guide_poses: the warp that maps each pose time (walk → 1.5× slower copy)"))
walk_session.add({"op": "succession", "root": "LeftShoulder", "s": 0.01, "l": 1.0})
after = walk_session.staggered().refinements - guided.refinements
assert np.array_equal(after, staggered.succession(guided, root="LeftShoulder", s=0.01, l=1.0).refinements
                      - guided.refinements)

# %% [markdown]
# ## One session, saved and replayed
#
# The three compositions chain in one session (and with the contact layer last); the file holds the op list
# and the path of the reference. **Check:** the saved session replays to the same bits.

# %%
walk_session.set_ops([dict(edit, pose=k), dict(succession, falloff={"frame": frame, "sigma": None}),
                      {"op": "guide_poses", "reference": {"path": str(folder / "slow_walk.bvh")}},
                      {"op": "keep_contacts"}])
walk_session.save(folder / "combined.json")
print(json.dumps(json.loads((folder / "combined.json").read_text())["ops"], indent=None)[:400], "…")
again = Session.load(folder / "combined.json").edited()
assert np.array_equal(again.local_quats, walk_session.edited().local_quats)
print(f"edited: {walk_session.edited().duration:.2f} s (source {walk.duration:.2f} s), replayed bit-exactly")

# %% [markdown]
# In the editors: the StaggerEditor's **propagate** toggle spreads every nudge and IK target, its **region**
# (σ, centre frame) limits s and τ and is drawn over the pose-probability plot and on the dope sheet; the
# WarpEditor's **retime: staggered poses** writes `guide_poses` in a session that holds staggered edits.
#
# ```python
# from stagger_nb.widgets import StaggerEditor, WarpEditor
# ed = StaggerEditor(walk); ed.model.propagate = True; ed.model.region = True
# WarpEditor(walk, reference=slow, session=ed.session).model.target = "poses"
# ```
