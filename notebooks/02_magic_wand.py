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
# # The magic wand (Dean, Lewis & Chalmers 2018)
#
# Edit one frame; let the motion itself decide how the edit fades in and out. The falloff is the Green's
# function of the *pose-space Laplacian*: a Gaussian kernel between all pairs of poses (Eq. 1), normalised
# (Eq. 2), the eigenvectors $\phi_k$ and eigenvalues $\lambda_k$ of its Laplacian, and the Green's function
# $G(p_i, p_j) = \sum_{k>0} \phi_k(p_i)\phi_k(p_j)/\lambda_k$ (Eq. 3). The edit is a log-quaternion
# delta (Eq. 4) added to every frame $j$ with weight $w_{ij}$ (Eq. 5): 1 at the edited frame, 0 at the most
# dissimilar frame of the chosen range.
#
# Like the paper we work at 30 Hz: the sample clips (60 Hz) are resampled with slerp.
# The pipeline has a cached head and a cheap tail, which is what makes a σ slider interactive:
#
# ```python
# graph = wand.pose_graph(m)        # pose vectors + all pose distances (once per clip)
# basis = graph.basis(sigma)        # eigenpairs of the Laplacian for one kernel width
# w = wand.greens_falloff(basis, frame, frame_range)   # (F,) in [0, 1]
# ```

# %%
import numpy as np
import plotly.graph_objects as go
import plotly.express as px

import stagger_nb as sn
from stagger_nb import wand
from stagger_nb.core.rotations import quat_mul, rotvec_to_quat

walk = sn.data.load("walk").resample(1 / 30)
run = sn.data.load("run").resample(1 / 30)
print("walk:", walk.num_frames, "frames; run:", run.num_frames, "frames at 30 Hz")

# %% [markdown]
# ## Figure 1 — Green's distance from one control frame
#
# The normalised pose distance $1 - w$ from frame 53 of the walk to every frame. It is 0 at the control
# frame (the yellow bar: the pose compared with itself) and dips again wherever the walk comes back to a
# similar pose: the gait is quasi-periodic, so the distance is too. Its small dents, bends and plateaus
# follow the phases of the step.

# %%
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

# %% [markdown]
# ## Figure 2 — a motion that is not periodic
#
# The real CMU clip 01_01: the actor jumps forward a few times, stops, turns around and comes back. The
# distance from a frame early in the clip has bends at the transitions between phases rather than a
# clean period; where an edit should stop is not obvious from the curve alone, which is why the artist
# chooses the frame range.

# %%
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

# %% [markdown]
# ## Figure 3 — Green's function vs ISOMAP vs diffusion distance
#
# Two manifold-learning distances for comparison, on the run cycle, from frame 53: ISOMAP (geodesic
# shortest paths in a k-nearest-neighbour graph) and the diffusion distance after 10 random-walk steps.
# All three find the same periodic structure (left). Zoomed in near the control frame (right), the
# Green's distance is *rounded*, the diffusion distance somewhat tapered and ISOMAP has a sharp corner —
# the sharp corner is what makes an edit "snap" in and out of the target pose.

# %%
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

# %% [markdown]
# ## Figure 5 — the kernel width σ
#
# σ in Eq. 1 sets which poses count as neighbours. Sweeping it from half to three times the data-derived
# default (blue = smaller σ) changes the distance a lot far from the control frame, while the valley
# around the control frame stays put (the paper notes an offset of 2–3 frames at bad values). Only the
# cheap tail of the pipeline (`graph.basis(sigma)`) runs per value.

# %%
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


# %% [markdown]
# ## Figure 4 — one edit, propagated over the run cycle
#
# The artist edits *only* frame 20: both thighs rotate 25° forward, lifting the knees. `wand.propagate`
# takes the log-quaternion difference of the edited pose (Eq. 4) and adds it to every frame with the
# Green's falloff weight (Eq. 5). Frames where the run comes back to the same phase get almost the whole
# edit — the knees are lifted in every stride with one edit.

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

# %% [markdown]
# ## Figure 6 — the Green's falloff vs a generic spline falloff
#
# In a simple case the data-driven falloff should behave like the spline falloff an animator would draw.
# We raise the left foot at the top of its swing in one step of the walk (the left knee bends 30° more) and
# spread the edit with (a) the Green's falloff restricted to that step (`repetitions=False`) and (b) a
# generic smooth spline bump of the same width at half height, as an animator would size it to the swing.
# Plotted is the ankle's vertical channel, as in the paper. (The Green's falloff is more peaked than the
# flat-topped spline: at 30 Hz the swing lasts only about ten frames, and the pose changes fastest there.)

# %%
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

# %% [markdown]
# ## The magic-wand editor
#
# Pick the edited frame and a joint, rotate it with the sliders, and watch the edit spread: the 3D view
# shows the result over the original ghost, the plot shows the falloff (with ISOMAP, diffusion and spline
# curves for comparison). The σ slider snaps to values whose eigenbases are precomputed in the background;
# the frame range and "repetitions" decide how far the edit may travel.

# %%
from stagger_nb.widgets import WandEditor
editor = WandEditor(run, frame=edit_frame, joint="LeftUpLeg")
editor
