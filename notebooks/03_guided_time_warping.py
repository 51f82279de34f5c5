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
# # Guided time warping (Hsu, da Silva & Popović 2007)
#
# A time warp changes *when* poses happen, never the poses. Given keytimes (at least a new duration) and a
# *reference motion*, guided time warping picks a subsequence of input frames — complete (first and last
# frame kept, no gap larger than `skip` frames) and monotonic (§3.1) — whose local velocities and
# accelerations look most like the reference's (the k-nearest-neighbour score of Eq. 2, §3.2). The best
# subsequence is found exactly by a constrained shortest-path dynamic programme (Eqs. 3–4, §3.3); the
# discrete warp is then smoothed and the motion resampled with slerp (§3.4). Expansions are compressions of
# an upsampled input.
#
# ```python
# out, warp = timewarp.guided_warp(m, reference, num_frames, skip=8, keytimes=None)
# out, warp = timewarp.linear_warp(m, num_frames)      # the spline-style baseline
# # warp: (num_frames,) input time in seconds of every output frame
# ```
#
# As in the paper everything runs at 30 Hz.

# %%
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

# %% [markdown]
# ## §4.1 Preservation — shorten and lengthen, using the motion as its own reference
#
# A linear warp (what a two-keytime spline warp does) speeds every part up equally, so the jumps become
# implausibly quick. With the input as its own reference, guided warping speeds through the walking and
# standing and keeps the jumps close to their real timing. Below: the warp curves (input time of every
# output frame) with the flight phases marked, and the local speed inside and outside the flights.

# %%
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

# %% [markdown]
# Plotted against output time, the root height shows what the numbers say: under the linear compression
# every jump is squeezed; the guided warp keeps each flight's duration and spends the saved time elsewhere.

# %%
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

# %% [markdown]
# ## §4.2 Modification — slow-motion jumps from one hand-made example (V8)
#
# The reference no longer has to be the input. Here an animator has slowed *one* jump down by hand (flight
# at 0.4× speed) — a 35-frame clip. Used as the reference for the whole capture, with the output length
# set to leave room for the slow motion, guided warping finds every other jump and slows it down the same
# way, although the jumps differ from the example, while the rest keeps playing at about real time.

# %%
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


# %% [markdown]
# ## §4.2 Modification — propagate a hand-edited limp (V7)
#
# One stride of the walk is retimed by hand to look like a limp: the left single-support phase plays at
# half speed, so the character lingers on the left leg. That 45-frame stride is the only reference; the
# guided warp gives the same timing to every stride of the walk. We count output frames in left and right
# single support: their ratio is about 1 in the walk and about 2 in the hand-edited stride.

# %%
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

# %% [markdown]
# ## Figure 5 — warp derivatives on a log scale
#
# The local speed of each warp (input seconds per output second). The centre line is real time; the limits
# are tenfold slow motion and tenfold fast forward. Linear warps are flat lines; guided warps speed up and
# slow down where the reference says so.

# %%
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

# %% [markdown]
# ## Table 1 — parameters and running times, measured now
#
# `n`, `m`, `r`: frame counts of the searched input (after upsampling for expansions), output and reference;
# `s`: the skip limit. *Objective*: features and the kNN score table (`prepare_warp`); *optimization*: the
# exact constrained dynamic programme (`solve_warp`); *heuristic*: the coarse-to-fine search that first
# solves at 1/8 resolution (§3.3). The paper's times are from a 2.4 GHz Pentium 4 with C++ and MATLAB;
# these are numpy on this machine.

# %%
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

# %% [markdown]
# ## The time-warping editor
#
# Set the target duration, the skip limit and keytimes, choose the reference — the input itself, a segment
# of it, or the hand-edited limp stride from above — and compare guided with linear warping. The plots
# show the warp curve and its derivative on the log scale of Fig. 5; the 3D view plays the result over the
# original ghost.

# %%
from stagger_nb.widgets import WarpEditor
editor = WarpEditor(walk, reference={"limp stride": limp})
editor
