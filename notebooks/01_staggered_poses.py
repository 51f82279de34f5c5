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
# # Staggered poses (Coleman, Bibliowicz, Singh & Gleicher 2008)
#
# A *staggered pose* is a key pose whose joints reach their extreme values at slightly different times:
# joint `i` of pose `k` has a value $v_{k,i}$ and a *timing refinement* $r_{k,i}$, so its knot sits at
# $t_k + r_{k,i}$ (§3). Between poses a spline carries the transition and a displacement map keeps every
# detail of the capture. Editing the few poses changes the stance; editing the refinements changes the
# *coordination*.
#
# Every figure below runs on **real motion capture**: CMU 01_01 (four hops forward, a turn-around, hops
# back) and a MocapBank capture of a person getting down and standing up. The procedural walk appears once,
# labelled, as a clean teaching aid whose staggering was programmed into it.
#
# ```python
# sm = staggered.extract(m)            # all candidate poses, refinements, splines, displacement maps
# sm = staggered.cull(sm, percent=50)  # keep the highest-priority half
# sm = staggered.succession(sm, root="LeftShoulder", s=0.03, l=2.0)
# m2 = staggered.evaluate(sm)          # back to a dense Motion
# ```

# %%
# set-up: clips, one extraction per clip, and two small helpers used by several figures
import dataclasses

import numpy as np
import plotly.io as pio

import stagger_nb as sn
from stagger_nb import plotting, staggered
from stagger_nb.core.rotations import quat_angle, quat_conj, quat_mul, quat_to_rotvec

cmu = sn.data.load("cmu_01_01").resample(1 / 30)          # real: hops, turn-around, hops back (30 Hz)
hops = cmu.slice(0, int(8.5 * 30))                         # its first 8.5 s: four hops forward, before the turn
sm = staggered.extract(hops)
get_down = sn.data.load("mocapbank_get_down")              # real: stands, gets down low, stands up (30 Hz)
walk = sn.data.load("walk")                                # procedural teaching aid (staggering programmed in)
J = hops.skeleton.index
dofs = ["LeftUpLeg", "LeftLeg", "LeftArm", "LeftForeArm"]   # hip, knee, shoulder, elbow: Fig. 1 and 2
js = [J(n) for n in dofs]


def channel(quats, j):
    """(..., J, 4) quaternions -> the main rotation-vector component of joint j over the hops, degrees."""
    axis = int(np.argmax(np.ptp(quat_to_rotvec(hops.local_quats[:, j]), axis=0)))
    return np.degrees(quat_to_rotvec(quats[..., j, :])[..., axis])


def strobe(motions, frames, names, colors, title, slots=None, spacing=80.0, view="front"):
    """Skeletons of several motions at given frames, each over its own root, placed in `slots` (default:
    one each) side by side across the view (along x for the front view, along z for the side view)."""
    pos = np.concatenate([sn.forward_kinematics(m)[0][[f]] for m, f in zip(motions, frames)])
    pos = pos - pos[:, :1] * [1, 0, 1]
    across = [1, 0, 0] if view == "front" else [0, 0, 1]
    shift = np.asarray(range(len(pos)) if slots is None else slots)[:, None] * spacing * np.asarray(across)
    return plotting.skeleton_strobe_figure(pos, motions[0].skeleton.parents, range(len(pos)), shift=shift,
                                           names=names, colors=colors, title=title, view=view)


print(f"hops: {hops.num_frames} frames at 30 Hz, {len(sm.pose_times)} candidate poses")

# %% [markdown]
# ## Figure 1 — aligned knots vs staggered knots
#
# **Claim (§3, Fig. 1).** A traditional pose puts one knot per degree of freedom at the *same* time (a);
# a staggered pose keeps one timing refinement per knot, so the extremes of the hip, knee, shoulder and
# elbow are reached at slightly different times (b).
#
# **Look at** one hop: in (a) every knot sits on a pose line, where the curves are *not* at their extremes;
# in (b) each knot moves towards its own curve's turning point, a few frames off the pose line.

# %%
win = (hops.times > 1.3) & (hops.times < 3.0)              # the first hop
ks = np.flatnonzero((sm.pose_times > 1.3) & (sm.pose_times < 3.0))
curves = np.stack([channel(hops.local_quats[win], j) for j in js])
aligned_t = np.repeat(sm.pose_times[ks, None], len(js), 1)
aligned_v = np.stack([channel(sm.editing_knots[ks], j) for j in js], 1)
pio.show(plotting.knots_figure(hops.times[win], curves, aligned_t, aligned_v, names=dofs,
                               pose_times=sm.pose_times[ks], title="Fig. 1a: one knot per DOF at the pose time"))
staggered_t = staggered.knot_times(sm)[ks][:, js]
staggered_v = np.stack([channel(sm.values[ks], j) for j in js], 1)
pio.show(plotting.knots_figure(hops.times[win], curves, staggered_t, staggered_v, names=dofs,
                               pose_times=sm.pose_times[ks], title="Fig. 1b: staggered knots at t_k + r_k,i"))

# %% [markdown]
# ## Figure 2 — rough poses vs refined timing
#
# **Claim (§1, Fig. 2).** Blocking a motion out with rough, aligned poses gives curves that all turn at
# once (b); refining the timing (c) turns each curve at its own time, and the coordination becomes hard
# to read in a spline editor. Staggered poses keep both: the poses of (b) *and* the timing of (c). Both
# plots show the splines through all candidate poses of the first two hops, without displacement maps.
#
# **Look at** how in (b) all four curves turn together at each dashed line; in (c) the turns spread out.
# **Try:** `staggered.random_timing(rough, tau=0.05, seed=1)` and watch coordination dissolve.

# %%
bare = dataclasses.replace(sm, displacements=np.zeros_like(sm.displacements),
                           root_displacements=np.zeros_like(sm.root_displacements))   # splines only
rough = dataclasses.replace(bare, refinements=np.zeros_like(bare.refinements))            # every knot at t_k
for label, v in (("(b) rough poses: knots aligned", rough), ("(c) refined timing: knots staggered", bare)):
    m = staggered.evaluate(v)
    keep = (m.times > 1.3) & (m.times < 4.3)               # the first two hops
    series = {n: (m.times[keep], channel(m.local_quats[keep], j)) for n, j in zip(dofs, js)}
    pio.show(plotting.lines_figure(series, vlines=v.pose_times[(v.pose_times > 1.3) & (v.pose_times < 4.3)],
                                   y_title="rotation (°)",
                                   title=f"Fig. 2{label}", height=280))

# %% [markdown]
# ## Figure 4 — evidence signals
#
# **Claim (§4.1, Fig. 4).** The scaled curvature of each limb's motion trail peaks when the limb changes
# direction, and those peaks *cluster*: many body parts turn at nearly the same time, slightly staggered.
# Contact starts and ends add a binary global signal.
#
# **Look at** the clusters around each take-off and landing of the hops (grey lines: extracted poses).

# %%
evidence = sm.metadata["evidence"]                        # (F, J + 2): joints, root translation, contacts
columns = list(hops.skeleton.names) + ["root translation", "contact events"]
shown = ["LeftUpLeg", "LeftLeg", "RightUpLeg", "RightLeg", "Spine", "LeftArm", "RightArm", "contact events"]
series = {n: (hops.times, evidence[:, columns.index(n)]) for n in shown}
pio.show(plotting.lines_figure(series, stacked=1.1, vlines=sm.pose_times, vline_color="#a0aec0", height=460,
                               title="Fig. 4: evidence signals p_i(t) of the real hops (offset for display)"))

# %% [markdown]
# ## Figure 5 — pose probability, candidates and culling
#
# **Claim (§4.1, Fig. 5).** The weighted, tent-filtered mean of the evidence is a *pose probability*
# $P(t)$; its peaks are candidate poses, prioritised by $w_k = P(t_k)(t_{k+1}-t_{k-1})$. Culling keeps the
# highest-priority ones. On a hop the body changes direction together at take-off and landing, so
# those moments should be peaks of $P$.
#
# **Check:** every take-off and landing has a candidate pose within 0.1 s (this could fail on a poor
# extraction). **Look at** the kept half: the priority favours *well-spaced* poses, so some events lose
# their pose. **Try:** `percent=75` — which events come back?

# %%
kept = staggered.cull(sm, percent=50)
P, f_of = sm.metadata["probability"], np.round(sm.pose_times / hops.frame_time).astype(int)
fk = np.round(kept.pose_times / hops.frame_time).astype(int)
pio.show(plotting.pose_probability_figure(hops.times, P, sm.pose_times, P[f_of], kept.pose_times, P[fk],
                                          title="Fig. 5: P(t) of the real hops, candidates and the kept half"))
toes = sn.forward_kinematics(hops)[0][:, [J("LeftToeBase"), J("RightToeBase")], 1].min(axis=1)
air = toes > np.percentile(toes, 5) + 8                   # both toes 8 cm above the floor
events = hops.times[np.flatnonzero(np.diff(air.astype(int))) + 1]
near = np.min(np.abs(events[:, None] - sm.pose_times[None]), axis=1)
print("take-off / landing times:", np.round(events, 2), "\ndistance to the nearest candidate (s):", np.round(near, 2))
assert near.max() < 0.1

# %% [markdown]
# The procedural walk, as a **clean teaching aid**: its staggering is programmed in, so the peaks are
# regular — compare how much less tidy the real hops are.

# %%
sm_walk = staggered.extract(walk)
Pw, fw = sm_walk.metadata["probability"], np.round(sm_walk.pose_times / walk.frame_time).astype(int)
kw = staggered.cull(sm_walk, percent=50)
kfw = np.round(kw.pose_times / walk.frame_time).astype(int)
pio.show(plotting.pose_probability_figure(walk.times, Pw, sm_walk.pose_times, Pw[fw], kw.pose_times, Pw[kfw],
                                          title="teaching aid (procedural walk): P(t), candidates, kept half"))

# %% [markdown]
# ### Timing refinements
#
# Each knot's refinement is the offset of the nearest peak of that joint's own evidence (within 0.25 s).
# **Look at** the columns: at a landing the legs lead and the arms follow (blue vs red).

# %%
ref_ms = 1000 * sm.refinements.T                          # (J, K) milliseconds
pio.show(plotting.heatmap_figure(ref_ms, [f"{t:.2f}" for t in sm.pose_times], hops.skeleton.names, colorbar="ms",
                                 x_title="pose time t_k (s)", title="timing refinements r_k,i of the real hops (ms)"))
print(f"{np.count_nonzero(sm.refinements)} of {sm.refinements.size} knots are staggered")

# %% [markdown]
# ## Figure 3 — splines and displacement maps
#
# **Claim (§4.1.1, Fig. 3).** Between refined knots each joint follows a spline, composed with a
# displacement map that holds whatever the spline misses: $v_i(t) = s_i(t') \oplus d_i(t')$. The
# representation is **exact**: evaluating it gives back the capture.
#
# **Look at** the upper arm: the spline carries the movement, the displacement map (below) is detail.

# %%
no_detail = dataclasses.replace(sm, displacements=np.zeros_like(sm.displacements),
                                root_displacements=np.zeros_like(sm.root_displacements))
spline_only, full = staggered.evaluate(no_detail), staggered.evaluate(sm)
j = J("LeftArm")
disp = channel(quat_mul(quat_conj(spline_only.local_quats), full.local_quats), j)
pio.show(plotting.spline_displacement_figure(
    hops.times, channel(hops.local_quats, j), channel(spline_only.local_quats, j), staggered.knot_times(sm)[:, j],
    channel(sm.values, j), disp, title="Fig. 3: left upper arm of the real hops — spline + displacement = data"))
err = np.degrees(quat_angle(full.local_quats, hops.local_quats)).max()
print(f"reconstruction error of the whole capture: {err:.1e} degrees")
assert err < 1e-6

# %% [markdown]
# ## Figure 6 — editing the pose and the non-staggered pose
#
# **Claim (§5.1, Fig. 6).** Each staggered pose has a *pose at t_k* (what the motion passes through) and a
# *non-staggered pose* (every joint at its extreme), which never occurs and usually looks exaggerated.
# `edit_pose` edits either and carries the change to the other, so the motion stays continuous.
#
# **Look at** the landing pose of the first hop: yellow is the true pose, orange the non-staggered one;
# right, both after turning the upper arms 0.6 rad about their local z axes (here: in towards the body).
# **Try** `mode="unstaggered"`, or the opposite signs.

# %%
k = int(np.argmin(np.abs(sm.pose_times - events[1])))    # the pose nearest the first landing
arms = {"LeftArm": [0.0, 0.0, -0.6], "RightArm": [0.0, 0.0, 0.6]}
edited = staggered.edit_pose(sm, k, deltas=arms, mode="staggered")
f_k = int(round(sm.pose_times[k] / hops.frame_time))
poses = [hops.replace(local_quats=q[None], root_positions=hops.root_positions[[f_k]]) for q in
         (sm.editing_knots[k], sm.values[k], edited.editing_knots[k], edited.values[k])]
pio.show(strobe(poses, [0] * 4, ["pose at t_k", "non-staggered", "pose at t_k, edited", "non-staggered, edited"],
                ["#d69e2e", "#dd6b20", "#d69e2e", "#dd6b20"], f"Fig. 6: pose {k} (t = {sm.pose_times[k]:.2f} s)"))

# %% [markdown]
# ## Figure 7 — linear and nonlinear succession
#
# **Claim (§5.2, Fig. 7).** Succession shifts refinements down a chain, $\hat r_{k,i} = r_{k,i} + s\,d(i)^l$:
# $l = 1$ is linear succession, larger $l$ looks looser. As in the paper, first widen the arms on the
# non-staggered poses (`exaggerate` from the mean), then loosen them with succession from the shoulders.
#
# **Look at** the elbow: with $l = 2$ its extremes arrive later than with $l = 1$.

# %%
arm = [n for s in ("Left", "Right") for n in (f"{s}Shoulder", f"{s}Arm", f"{s}ForeArm", f"{s}Hand")]
inner = list(range(1, len(sm.pose_times) - 1))
geo = staggered.exaggerate(sm, inner, 0.5, reference="mean", mode="unstaggered", joints=arm)
variants = {"(c) original": sm, "(d) arms exaggerated": geo}
for l in (1.0, 2.0):
    both = staggered.succession(staggered.succession(geo, root="LeftShoulder", s=0.03, l=l), root="RightShoulder",
                                s=0.03, l=l)
    variants[f"(e) + succession l={l:g}"] = both
series = {n: (hops.times, np.degrees(quat_angle(staggered.evaluate(v).local_quats[:, J("LeftForeArm")])))
          for n, v in variants.items()}
pio.show(plotting.lines_figure(series, y_title="elbow rotation (°)", title="Fig. 7: left elbow of the real hops"))

# %% [markdown]
# ## Figure 8 — geometric and temporal edits together
#
# **Claim (§6, Fig. 8).** The tools combine: a stronger anticipation before standing up (geometric:
# exaggerate the lowest pose) and a looser rise (temporal: succession up from the hips). Original frames
# light blue, edited violet, as in the paper.
#
# **Look at** the lowest pose (left pair) and half-way up (right pair). **Try** `l=2`.

# %%
sg = staggered.extract(get_down)
low = int(np.argmin(staggered.evaluate(sg, sg.pose_times).root_positions[:, 1]))
lifted = staggered.exaggerate(sg, [low], 0.6, reference="mean", mode="staggered")
lifted = staggered.succession(lifted, root="Hips", s=0.04, l=1.0)
out = staggered.evaluate(lifted)
y = get_down.root_positions[:, 1]
f_low = int(round(sg.pose_times[low] / get_down.frame_time))
f_rise = int(np.flatnonzero((y > (y.min() + y.max()) / 2) & (np.arange(len(y)) > f_low))[0])   # half-way up
pio.show(strobe([get_down, out, get_down, out], [f_low, f_low, f_rise, f_rise],
                ["original, lowest", "edited, lowest", "original, half-way up", "edited, half-way up"],
                ["#90cdf4", "#805ad5", "#90cdf4", "#805ad5"], "Fig. 8: anticipation and a looser rise (MocapBank)",
                slots=[0, 0, 1, 1], spacing=120.0, view="side"))

# %% [markdown]
# ## Contacts kept planted
#
# **Claim (§3, App. B).** Timing edits move feet that should stay down; a constraint layer carries each
# contact through the edit and holds it. A deliberately rough edit (succession from the hips + random
# timing everywhere) makes the feet slide on the real hops; `keep_contacts` plants them again, each contact
# carried on the pelvis's timing (the joint the legs hang from), where the source holds it (its heel-toe roll
# kept), the pelvis lowered by at most 2.8 % of a leg and moved aside by at most 15 % (no held joint turns over
# 2.5° a frame faster than in the source).
#
# **Check** (`sn.quality.compare`, cm of a 170 cm body): inside the carried contacts, the layer removes at
# least 80 % of the feet's sliding against the source's own motion there, and moves the pelvis by less than
# 3 cm.

# %%
rough_edit = staggered.random_timing(staggered.succession(sm, root="Hips", s=0.02, l=1.0), tau=0.05, seed=1)
slid, held = staggered.evaluate(rough_edit), staggered.keep_contacts(rough_edit, hops)
without = sn.quality.compare(hops, slid, staggered=rough_edit)
with_layer = sn.quality.compare(hops, held, staggered=rough_edit, baseline=slid)
ankle = {n: (m.times, sn.forward_kinematics(m)[0][:, J("RightFoot"), 1]) for n, m in
         (("original", hops), ("edited", slid), ("edited + keep_contacts", held))}
pio.show(plotting.lines_figure(ankle, y_title="right ankle height (cm)", title="contacts after a rough timing edit"))
print(f"feet slide {without.foot_travel:.1f} cm without the layer, {with_layer.foot_travel:.1f} cm with it; "
      f"pelvis moved {with_layer.pelvis_vs_baseline:.1f} cm by the layer")
assert with_layer.foot_travel < 0.2 * without.foot_travel
assert with_layer.pelvis_vs_baseline < 3.0

# %% [markdown]
# ## The staggered-pose editor
#
# Everything above, interactively, on the real hops: the 3D view plays the edit over a grey ghost; below
# it the joint curves and the pose probability. Every change is an op in `editor.session` (undo / redo;
# `editor.session.save(path)` keeps it).

# %%
from stagger_nb.widgets import StaggerEditor

editor = StaggerEditor(hops)
editor
