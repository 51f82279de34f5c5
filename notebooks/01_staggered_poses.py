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
# A *staggered pose* is a key pose whose degrees of freedom reach their extreme values at slightly different
# times: each joint `i` of pose `k` has a value $v_{k,i}$ and a *timing refinement* $r_{k,i}$, so its knot sits
# at $t_k + r_{k,i}$ (paper §3, Fig. 1). Between poses, a spline carries the low-frequency transition and a
# displacement map keeps every detail of the captured motion (Fig. 3). Editing the few poses changes the
# stance; editing the refinements changes the *coordination* — succession down a limb, or random asymmetry.
#
# This notebook follows the paper: find the poses in dense motion (§4.1, Fig. 4 and 5), fit splines and
# displacement maps (§4.1.1, Fig. 3), edit a pose geometrically (§5.1, Fig. 6), edit the timing with linear
# and nonlinear succession and random offsets (§5.2, Fig. 7), and keep the feet planted (§3, App. B).
#
# ```python
# sm = staggered.extract(m)            # all candidate poses, refinements, splines, displacement maps
# sm = staggered.cull(sm, percent=50)  # keep the highest-priority half
# sm = staggered.succession(sm, root="LeftShoulder", s=0.03, l=2.0)
# m2 = staggered.evaluate(sm)          # back to a dense Motion
# ```

# %%
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

# %% [markdown]
# ## Figure 4 — evidence signals
#
# For every joint, the *scaled curvature* $\hat\kappa = n\cdot e/|e| \in [0, 1]$ of the local-space motion
# trails of its limb axes (two trails per child, so twist counts too), smoothed; the root translation gets
# its own trail, and contact starts and ends are a binary global signal. Peaks mark direction changes.
# They *cluster*: many body parts change direction at nearly the same time, slightly staggered — the grey
# lines are the extracted pose times.

# %%
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

# %% [markdown]
# ## Figure 5 — the pose probability signal, candidates and priorities
#
# The weighted mean of the signals ($w_i$ = limb length × trail arc length: limbs that move a lot count
# more) is low-pass filtered with a 0.15 s tent, which merges each cluster into one peak: the *pose
# probability* $P(t)$. Every local maximum (plus the first and last frame) is a candidate pose. Each gets the
# priority $w_k = P(t_k)(t_{k+1} - t_{k-1})$, favouring likely poses with distant neighbours; culling keeps
# the highest-priority fraction.

# %%
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

# %% [markdown]
# ### Timing refinements
#
# For each pose and joint, the refinement is the offset of the nearest peak of that joint's own evidence
# (within 0.25 s and closer to this pose than to the neighbours; 0 if none). The table shows how the
# extremes of a run's stance are staggered across the body, in milliseconds.

# %%
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

# %% [markdown]
# ## Figure 3 — splines and displacement maps
#
# Between two staggered poses each joint follows a cubic quaternion spline (recursive slerp, fitted to the
# samples, App. A) in a normalised time $t'$ between its own refined knots, composed with a displacement
# map that holds whatever the spline misses: $v_i(t) = s_i(t') \oplus d_i(t')$. Below, the main rotation
# channel of two joints of the run: the data, the spline alone (displacement maps set to zero), the
# knots at the refined times, and the displacement. For the upper arm the spline carries the movement and
# the displacement is small detail, as in the paper's figure. The knee bends twice per stride — more often
# than there are staggered poses — so there the displacement map carries a large part of the movement;
# the sum is still exact.

# %%
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


# %% [markdown]
# ## Figure 6 — geometric editing of a pose and of the non-staggered pose
#
# Two poses belong to each staggered pose: the *pose at the staggered pose time* (every joint evaluated at
# $t_k$: the editing knots $v^0_{k,i}$) and the *non-staggered pose* (every joint at its extreme value
# $v_{k,i}$). The non-staggered pose never occurs in the motion; it usually looks like an exaggeration of
# the true pose. `edit_pose` edits either one (`mode="staggered"` or `"unstaggered"`) and carries the same
# change to the other knot, so the motion stays continuous (§5.1). Here: the walk's arms, a 0.35 rad turn
# of both upper arms, edited at one pose.

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

# %% [markdown]
# ## Figure 7 — temporal editing: linear and nonlinear succession, random timing
#
# Succession shifts refinements down a chain: $\hat r_{k,i} = r_{k,i} + s\,d(i)^l$, with $d(i)$ the number
# of bones from a chosen joint. $l = 1$ is Neff & Fiume's linear succession; larger $l$ makes the limb look
# looser, more cartoony. Random timing adds $U(-\tau, \tau)$ per knot (seeded). As in the paper's Fig. 7,
# we first widen the arm swing on the non-staggered poses (`exaggerate` relative to the mean pose), then
# loosen the arms with nonlinear succession from the shoulders. Plotted: the left elbow's rotation in the
# original (c), after the geometric edit (d), and after geometric + temporal edits with $l = 1$ and $l = 2$ (e).

# %%
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

# %% [markdown]
# ## Contacts kept planted
#
# Timing edits move feet that should stay on the ground. Contacts are found by looking for end effectors
# that stay still for at least 0.25 s (App. B); after an edit, a constraint displacement layer (two-bone IK
# on each leg, faded in and out over 0.15 s) puts them back where the original motion had them (§3). Here a
# deliberately rough edit — succession from the hips plus random timing on every joint — makes the feet
# slide; the constraint layer removes most of the slide.

# %%
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

# %% [markdown]
# ## The staggered-pose editor
#
# Everything above, interactively. The 3D view plays the edited walk with the original as a grey ghost;
# below it, the joint curves with the pose times and refinement knots, and the pose probability with the
# candidate and kept poses. The sliders set the percentage of poses kept (culling by priority), the
# succession root, `s` and `l`, random timing `τ` and seed, and exaggeration `w_r`. Every change is an op
# in `editor.session` (undo / redo buttons; `editor.session.save(path)` keeps it).

# %%
from stagger_nb.widgets import StaggerEditor
editor = StaggerEditor(walk)
editor
