"""Deterministic procedural sample clips on a CMU-like 31-joint skeleton: walk, run, jump.

So that tests and notebooks have motion on any machine, without downloads. Units are centimetres,
Y is up, the character faces and travels along +Z, 60 Hz. Each clip is built the way an animator
would block it:

1. a root trajectory (forward travel, vertical bob, and for the run and the jump ballistic flight
   phases where the root height is exactly the parabola ``y0 + v0 t - g t^2 / 2``, g = 981 cm/s^2);
2. a schedule of foot plants ``(t_on, t_off, position)``; during stance the ankle stays exactly on its
   plant and the foot stays flat, during swing it follows a minimum-jerk arc with a ``sin^2`` lift;
3. the root height is softly limited so every planted ankle stays within reach of its hip;
4. each leg is solved by analytic two-bone IK (knee in the plane of hip, ankle and the forward
   direction), the foot's world orientation is imposed through the ankle's local rotation;
5. pelvis twist, counter-twisting spine, a head that keeps looking ahead, arm swing opposite to the
   legs with a small phase lag, elbows, and a little seeded, smoothed noise on the upper body
   (detail for displacement maps).

Public: :func:`cmu_skeleton`, :func:`walk`, :func:`run`, :func:`jump`, :func:`generate`,
:data:`CLIPS`. All are pure functions of their arguments (same arguments, same arrays).
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicHermiteSpline
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from ..core.motion import Motion
from ..core.rotations import euler_to_quat, quat_conj, quat_mul, quat_rotate
from ..core.skeleton import Skeleton

__all__ = ["cmu_skeleton", "walk", "run", "jump", "generate", "CLIPS", "FPS", "GRAVITY",
           "THIGH", "SHIN", "ANKLE_HEIGHT"]

FPS = 60.0             # frames per second of every clip
GRAVITY = 981.0        # cm / s^2
THIGH = 42.0           # cm, hip to knee
SHIN = 42.0            # cm, knee to ankle
ANKLE_HEIGHT = 8.0     # cm, ankle above the ground when the foot is flat
_HIP = (9.0, -8.0, 0.0)    # cm, left hip joint from the pelvis centre
_FOOT_X = 10.0             # cm, lateral position of a planted ankle from the travel line
_REACH = 0.99 * (THIGH + SHIN)  # cm, the farthest a planted ankle may be from its hip
_SOFT = 0.5                # cm, smoothness of the soft minimum that keeps ankles in reach
_ARM_HANG = 75.0           # degrees, arms from T-pose down to the sides

# (name, parent name, offset cm, end-site offset cm or None), CMU / MotionBuilder-friendly layout
_LAYOUT = [
    ("Hips", None, (0, 0, 0), None),
    ("LHipJoint", "Hips", (0, 0, 0), None),
    ("LeftUpLeg", "LHipJoint", _HIP, None),
    ("LeftLeg", "LeftUpLeg", (0, -THIGH, 0), None),
    ("LeftFoot", "LeftLeg", (0, -SHIN, 0), None),
    ("LeftToeBase", "LeftFoot", (0, -6.5, 13.0), (0, 0, 6.0)),
    ("RHipJoint", "Hips", (0, 0, 0), None),
    ("RightUpLeg", "RHipJoint", (-_HIP[0], _HIP[1], _HIP[2]), None),
    ("RightLeg", "RightUpLeg", (0, -THIGH, 0), None),
    ("RightFoot", "RightLeg", (0, -SHIN, 0), None),
    ("RightToeBase", "RightFoot", (0, -6.5, 13.0), (0, 0, 6.0)),
    ("LowerBack", "Hips", (0, 0, 0), None),
    ("Spine", "LowerBack", (0, 12.0, -1.0), None),
    ("Spine1", "Spine", (0, 12.0, 0.5), None),
    ("Neck", "Spine1", (0, 0, 0), None),
    ("Neck1", "Neck", (0, 21.0, 1.0), None),
    ("Head", "Neck1", (0, 10.0, 0.5), (0, 15.0, 0)),
    ("LeftShoulder", "Spine1", (0, 0, 0), None),
    ("LeftArm", "LeftShoulder", (17.0, 19.0, -1.0), None),
    ("LeftForeArm", "LeftArm", (28.0, 0, 0), None),
    ("LeftHand", "LeftForeArm", (25.0, 0, 0), None),
    ("LeftFingerBase", "LeftHand", (0, 0, 0), None),
    ("LeftHandIndex1", "LeftFingerBase", (8.0, 0, 0), (4.0, 0, 0)),
    ("LThumb", "LeftHand", (2.0, 0, 2.5), (3.0, 0, 3.0)),
    ("RightShoulder", "Spine1", (0, 0, 0), None),
    ("RightArm", "RightShoulder", (-17.0, 19.0, -1.0), None),
    ("RightForeArm", "RightArm", (-28.0, 0, 0), None),
    ("RightHand", "RightForeArm", (-25.0, 0, 0), None),
    ("RightFingerBase", "RightHand", (0, 0, 0), None),
    ("RightHandIndex1", "RightFingerBase", (-8.0, 0, 0), (-4.0, 0, 0)),
    ("RThumb", "RightHand", (-2.0, 0, 2.5), (-3.0, 0, 3.0)),
]


def cmu_skeleton() -> Skeleton:
    """The 31-joint CMU-like skeleton (joint names of the CMU MotionBuilder-friendly BVH files), in cm,
    Y up, facing +Z, T-pose at rest. Root channels ``X/Y/Zposition Z/Y/Xrotation``, the others ``Z/Y/X``."""
    names = [r[0] for r in _LAYOUT]
    parents = [-1 if r[1] is None else names.index(r[1]) for r in _LAYOUT]
    offsets = np.array([r[2] for r in _LAYOUT], dtype=float)
    rot = ("Zrotation", "Yrotation", "Xrotation")
    channels = [("Xposition", "Yposition", "Zposition") + rot] + [rot] * (len(names) - 1)
    end_sites = {j: np.array(r[3], dtype=float) for j, r in enumerate(_LAYOUT) if r[3] is not None}
    return Skeleton(tuple(names), np.array(parents), offsets, tuple(channels), end_sites)


# ---------------------------------------------------------------------------------------------
# small helpers

def _euler(order: str, deg: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles in degrees (F, 3) -> quaternions (F, 4) (the package's one conversion)."""
    return euler_to_quat(np.asarray(deg, dtype=float), order)


def _axis_quat(axis: str, deg: np.ndarray) -> np.ndarray:
    """Rotation about one axis by ``deg (F,)`` degrees -> (F, 4)."""
    return euler_to_quat(np.asarray(deg, dtype=float).reshape(-1, 1), axis)


def _min_jerk(s: np.ndarray) -> np.ndarray:
    """0 -> 1 with zero velocity and acceleration at both ends."""
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def _smoothstep(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """0 before ``t0``, 1 after ``t1``, minimum-jerk in between."""
    return _min_jerk(np.clip((t - t0) / (t1 - t0), 0.0, 1.0))


def _softmin(a: np.ndarray, b: np.ndarray, k: float = _SOFT) -> np.ndarray:
    """Smooth minimum; equals ``a`` exactly where ``b`` is +inf."""
    m = np.minimum(a, b)
    with np.errstate(invalid="ignore", over="ignore"):
        r = m - k * np.log(np.exp(-(a - m) / k) + np.exp(-(b - m) / k))
    return np.where(np.isinf(b), a, r)


def _hermite(keys, t: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite through ``keys = [(t, value, slope), ...]``, held constant outside."""
    k = np.asarray(keys, dtype=float)
    spline = CubicHermiteSpline(k[:, 0], k[:, 1], k[:, 2])
    tc = np.clip(t, k[0, 0], k[-1, 0])
    return spline(tc)


def _noise(rng: np.random.Generator, n: int, dims: int, deg: float, sigma_frames: float = 8.0) -> np.ndarray:
    """Smoothed Gaussian noise (n, dims), roughly ``deg`` degrees standard deviation."""
    w = gaussian_filter1d(rng.standard_normal((n, dims)), sigma_frames, axis=0, mode="nearest")
    return w * (deg / max(float(np.std(w)), 1e-12))


class _Plants:
    """Foot plants of one foot: stance intervals ``[t_on, t_off]`` at ``xz (n, 2)`` (cm), sorted;
    ``lift`` (cm, scalar or (n,)) is the ankle's rise during the swing that follows each plant."""

    def __init__(self, t_on, t_off, xz, lift):
        self.t_on = np.asarray(t_on, dtype=float)
        self.t_off = np.asarray(t_off, dtype=float)
        self.xz = np.asarray(xz, dtype=float).reshape(-1, 2)
        self.lift = np.broadcast_to(np.asarray(lift, dtype=float), self.t_on.shape)

    def evaluate(self, t: np.ndarray):
        """Ankle targets (F, 3), foot pitch (F,) degrees, stance mask (F,) at times ``t``."""
        i = np.searchsorted(self.t_on, t, side="right") - 1      # last plant that started
        if np.any(i < 0) or np.any(i >= len(self.t_on)):
            raise ValueError("plants must cover the whole clip")
        stance = t <= self.t_off[i]
        j = np.minimum(i + 1, len(self.t_on) - 1)
        if np.any(~stance & (j == i)):
            raise ValueError("plants must cover the whole clip")
        s = np.where(stance, 0.0, (t - self.t_off[i]) / np.maximum(self.t_on[j] - self.t_off[i], 1e-9))
        s = np.clip(s, 0.0, 1.0)
        m = _min_jerk(s)[:, None]
        xz = self.xz[i] * (1.0 - m) + self.xz[j] * m
        bump = np.sin(np.pi * s) ** 2
        y = ANKLE_HEIGHT + self.lift[i] * bump
        pos = np.stack([xz[:, 0], y, xz[:, 1]], axis=-1)
        pitch = -12.0 * np.sin(2.0 * np.pi * s) * (s > 0)   # toes down after lift-off, up before contact
        return pos, np.where(stance, 0.0, pitch), stance


def _cycle_plants(t_end: float, period: float, duty: float, phase: float, root_z, x: float, lift: float,
                  first: int = -2):
    """Periodic plants: stance centred at ``(i + phase) * period`` under the root, lasting ``duty*period``."""
    idx = np.arange(first, int(np.ceil(t_end / period)) + 2)
    tc = (idx + phase) * period
    half = 0.5 * duty * period
    xz = np.stack([np.full(tc.shape, x), root_z(tc)], axis=-1)
    return tc - half, tc + half, xz, lift


# ---------------------------------------------------------------------------------------------
# the solver shared by all clips

def _two_bone(hip: np.ndarray, ankle: np.ndarray, forward: np.ndarray):
    """Analytic two-bone IK. ``hip, ankle (F, 3)``, ``forward (3,)`` knee direction hint.

    Returns world rotations (F, 4) of the thigh and the shin whose rest frames have the bone along
    -Y and the knee hinge along +X (as in :func:`cmu_skeleton`)."""
    d = ankle - hip
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    dhat = d / np.maximum(dist, 1e-9)
    dist = np.clip(dist, 1e-6, 0.999999 * (THIGH + SHIN))
    cos_a = (THIGH ** 2 + dist ** 2 - SHIN ** 2) / (2.0 * THIGH * dist)
    sin_a = np.sqrt(np.clip(1.0 - cos_a ** 2, 0.0, 1.0))
    e = forward - np.sum(forward * dhat, axis=-1, keepdims=True) * dhat
    e = e / np.maximum(np.linalg.norm(e, axis=-1, keepdims=True), 1e-12)
    knee = hip + THIGH * (cos_a * dhat + sin_a * e)
    ankle_reached = knee + SHIN * _unit(hip + dhat * dist - knee)
    n = np.cross(e, dhat)                      # hinge axis, +X at rest

    def frame(bone_dir):
        y = -bone_dir
        z = np.cross(n, y)
        return Rotation.from_matrix(np.stack([n, y, z], axis=-1)).as_quat()

    return frame(_unit(knee - hip)), frame(_unit(ankle_reached - knee))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _build(t: np.ndarray, root_xz: np.ndarray, root_y: np.ndarray, pelvis: np.ndarray,
           spine: np.ndarray, head: np.ndarray, arm_swing: np.ndarray, elbow: np.ndarray,
           plants: tuple, seed: int, noise_deg: float, return_contacts: bool = False):
    """Assemble a Motion.

    t (F,) s; root_xz (F, 2) cm; root_y (F,) nominal pelvis height cm (lowered softly where a planted
    ankle would be out of reach); pelvis (F, 3) YXZ Euler degrees (yaw, pitch forward, roll);
    spine (F, 3) YXZ degrees shared by LowerBack/Spine/Spine1; head (F, 2) extra (yaw, pitch) degrees;
    arm_swing (F, 2) L/R degrees forward; elbow (F, 2) L/R flexion degrees; plants (left, right) _Plants.
    Returns the Motion, or ``(motion, {"LeftFoot": (F,) bool, "RightFoot": (F,) bool})`` stance masks.
    """
    skel = cmu_skeleton()
    F, J = len(t), skel.num_joints
    rng = np.random.default_rng(seed)
    ix = skel.index
    q = np.zeros((F, J, 4))
    q[..., 3] = 1.0

    q_pelvis = _euler("YXZ", pelvis)
    q[:, 0] = q_pelvis
    # -- feet and root height
    feet = [p.evaluate(t) for p in plants]
    hips_local = [np.array(_HIP), np.array([-_HIP[0], _HIP[1], _HIP[2]])]
    y = np.asarray(root_y, dtype=float)
    for (ankle, _, stance), off in zip(feet, hips_local):
        h = quat_rotate(q_pelvis, off)                      # (F, 3) hip joint from the pelvis centre
        horiz = (root_xz[:, 0] + h[:, 0] - ankle[:, 0]) ** 2 + (root_xz[:, 1] + h[:, 2] - ankle[:, 2]) ** 2
        y_max = ankle[:, 1] - h[:, 1] + np.sqrt(np.maximum(_REACH ** 2 - horiz, 0.0))
        y = _softmin(y, np.where(stance, y_max, np.inf))
    root = np.stack([root_xz[:, 0], y, root_xz[:, 1]], axis=-1)

    # -- legs by two-bone IK
    fwd = np.array([0.0, 0.0, 1.0])
    for side, (ankle, pitch, _), off in zip(("Left", "Right"), feet, hips_local):
        hip = root + quat_rotate(q_pelvis, off)
        w_thigh, w_shin = _two_bone(hip, ankle, fwd)
        w_foot = _axis_quat("x", pitch)
        q[:, ix(f"{side}UpLeg")] = quat_mul(quat_conj(q_pelvis), w_thigh)   # *HipJoint is identity
        q[:, ix(f"{side}Leg")] = quat_mul(quat_conj(w_thigh), w_shin)
        q[:, ix(f"{side}Foot")] = quat_mul(quat_conj(w_shin), w_foot)

    # -- upper body
    nz = _noise(rng, F, 12, noise_deg)
    for k, name in enumerate(("LowerBack", "Spine", "Spine1")):
        q[:, ix(name)] = _euler("YXZ", spine / 3.0 + nz[:, 3 * k:3 * k + 3] * 0.5)
    # the head looks ahead: undo pelvis and spine yaw / pitch, then add its own motion
    total_yaw = pelvis[:, 0] + spine[:, 0]
    total_pitch = pelvis[:, 1] + spine[:, 1]
    q[:, ix("Neck")] = _euler("YXZ", np.stack([-0.5 * total_yaw, -0.3 * total_pitch, -0.5 * pelvis[:, 2]], -1))
    q[:, ix("Neck1")] = _euler("YXZ", np.stack([-0.5 * total_yaw + head[:, 0], -0.4 * total_pitch + head[:, 1],
                                                nz[:, 9]], -1))
    for side, sgn, k in (("Left", 1.0, 0), ("Right", -1.0, 1)):
        hang = _axis_quat("z", np.full(F, -sgn * _ARM_HANG))
        swing = _axis_quat("x", -arm_swing[:, k] + nz[:, 10 + k])
        q[:, ix(f"{side}Arm")] = quat_mul(swing, hang)
        q[:, ix(f"{side}ForeArm")] = _axis_quat("y", -sgn * elbow[:, k])
        q[:, ix(f"{side}Hand")] = _axis_quat("z", -sgn * (10.0 + 0.5 * nz[:, 10 + k]))
        q[:, ix(f"{side}FingerBase")] = _axis_quat("z", np.full(F, -sgn * 15.0))
    motion = Motion(skel, 1.0 / FPS, root, q)
    if return_contacts:
        return motion, {"LeftFoot": feet[0][2].copy(), "RightFoot": feet[1][2].copy()}
    return motion


def _gait_upper(w: np.ndarray, duty: float, twist: float, roll: float, arm: float, elbow: float,
                lag: float, weight=1.0):
    """Periodic upper-body signals (degrees) of a gait whose left stance is centred at ``w = 0 (mod 2 pi)``.

    The pelvis turns the leading leg's hip forward at each heel strike, the thorax counter-rotates,
    each arm swings forward while the opposite leg leads and lags the legs by ``lag`` radians.
    Returns pelvis yaw, pelvis roll, spine yaw, spine roll (F,) and arm swing, elbow change (F, 2)."""
    ph = w - 2.0 * np.pi * (0.5 - 0.5 * duty)      # 0 at the right heel strike
    c, cl = np.cos(ph), np.cos(ph - lag)
    g = np.asarray(weight, dtype=float)
    lr = np.stack([cl, -cl], -1) * (g[..., None] if g.ndim else g)   # +1 left, -1 right
    return (g * twist * c, g * roll * np.cos(w), -g * 1.6 * twist * np.cos(ph - 0.5 * lag),
            -g * 0.7 * roll * np.cos(w), arm * lr, elbow * lr)


def _times(duration: float) -> np.ndarray:
    return np.arange(int(round(duration * FPS)) + 1) / FPS


# ---------------------------------------------------------------------------------------------
# the clips

def walk(duration: float = 6.0, speed: float = 100.0, period: float = 1.1, seed: int = 0,
         return_contacts: bool = False):
    """A straight walk along +Z.

    Parameters
    ----------
    duration : seconds (default 6 s = 361 frames at 60 Hz, about 5.5 gait cycles)
    speed : cm/s forward
    period : seconds per gait cycle (two steps); each foot is planted 60 % of it
    seed : seed of the small upper-body noise

    return_contacts : also return ``{"LeftFoot": (F,) bool, "RightFoot": (F,) bool}``, the frames
        in which each foot is planted (ground truth for contact detection)

    Left foot stance is centred at ``t = i * period``, the right foot's half a cycle later.
    Returns a Motion (or ``(motion, contacts)``).
    """
    _check(duration=duration, speed=speed, period=period)
    t = _times(duration)
    w = 2.0 * np.pi * t / period
    root_z = lambda tt: speed * np.asarray(tt)  # noqa: E731
    lp = _Plants(*_cycle_plants(duration, period, 0.6, 0.0, root_z, _FOOT_X, 9.0))
    rp = _Plants(*_cycle_plants(duration, period, 0.6, 0.5, root_z, -_FOOT_X, 9.0))
    root_xz = np.stack([2.0 * np.cos(w), root_z(t)], -1)            # sway over the stance foot
    root_y = 94.0 + 1.5 * np.cos(2.0 * w)                           # highest at mid-stance
    p_yaw, p_roll, s_yaw, s_roll, arm, d_elbow = _gait_upper(w, 0.6, twist=6.0, roll=3.0, arm=22.0,
                                                              elbow=10.0, lag=0.35)  # lag: radians
    pelvis = np.stack([p_yaw, 3.0 + 1.0 * np.cos(2 * w), p_roll], -1)
    spine = np.stack([s_yaw, 2.0 * np.ones_like(t), s_roll], -1)
    head = np.stack([np.zeros_like(t), 1.0 * np.cos(2 * w - 0.5)], -1)
    elbow = 18.0 + d_elbow
    return _build(t, root_xz, root_y, pelvis, spine, head, arm, elbow, (lp, rp), seed, 0.6, return_contacts)


def run(duration: float = 5.0, speed: float = 300.0, period: float = 0.72, seed: int = 1,
        return_contacts: bool = False):
    """A straight run along +Z with flight phases.

    Each foot is planted 32 % of the cycle, so twice per cycle neither foot touches the ground for
    ``0.18 * period`` seconds; then the root height is the ballistic parabola with
    g = :data:`GRAVITY`, and during stance it dips by a sine matched to the parabola's take-off and
    landing speeds. Default 5 s = 301 frames.
    """
    _check(duration=duration, speed=speed, period=period)
    duty = 0.32
    t = _times(duration)
    w = 2.0 * np.pi * t / period
    root_z = lambda tt: speed * np.asarray(tt)  # noqa: E731
    lp = _Plants(*_cycle_plants(duration, period, duty, 0.0, root_z, 0.6 * _FOOT_X, 22.0))
    rp = _Plants(*_cycle_plants(duration, period, duty, 0.5, root_z, -0.6 * _FOOT_X, 22.0))
    root_y = run_height(t, period, duty)
    root_xz = np.stack([1.0 * np.cos(w), root_z(t)], -1)
    p_yaw, p_roll, s_yaw, s_roll, arm, d_elbow = _gait_upper(w, duty, twist=8.0, roll=2.0, arm=38.0,
                                                              elbow=15.0, lag=0.3)
    pelvis = np.stack([p_yaw, 8.0 + np.zeros_like(t), p_roll], -1)
    spine = np.stack([s_yaw, 4.0 + 2.0 * np.cos(2 * w), s_roll], -1)
    head = np.stack([np.zeros_like(t), -4.0 + 1.5 * np.cos(2 * w - 0.5)], -1)
    elbow = 85.0 + d_elbow
    return _build(t, root_xz, root_y, pelvis, spine, head, arm, elbow, (lp, rp), seed, 0.8, return_contacts)


def run_height(t: np.ndarray, period: float, duty: float, y0: float = 90.0) -> np.ndarray:
    """Nominal root height (cm) of :func:`run` at times ``t (F,)``: a parabola in each flight phase,
    ``y0 - A sin(pi s)`` during each stance (``s`` in [0, 1]), with ``A`` making the vertical speed
    continuous at take-off and landing."""
    half = 0.5 * period                     # one step: a stance then a flight
    ts, tf = duty * period, half - duty * period
    v0 = 0.5 * GRAVITY * tf                 # take-off vertical speed of a flight of tf seconds
    amp = v0 * ts / np.pi
    # stance of a step is centred on a multiple of half a period
    u = np.mod(t + 0.5 * ts, half)          # time since the current stance started
    stance = u <= ts
    tau = u - ts                            # time since take-off
    return np.where(stance, y0 - amp * np.sin(np.pi * u / ts), y0 + v0 * tau - 0.5 * GRAVITY * tau ** 2)


# key times of the jump (seconds), exported for tests and notebooks
JUMP_TIMES = {"gather": 1.80, "crouch": 2.10, "takeoff": 2.45, "landing": 2.90, "absorb": 3.10}
_JUMP_VZ = 220.0  # cm/s forward speed in flight


def jump(duration: float = 5.5, seed: int = 2, return_contacts: bool = False):
    """Walk in, gather both feet, crouch, take off, fly, land, walk out (default 331 frames).

    In flight (``JUMP_TIMES["takeoff"] <= t <= JUMP_TIMES["landing"]``) the root follows the
    ballistic parabola exactly: height ``y0 + v0 t - g t^2 / 2`` with g = :data:`GRAVITY`, forward
    position linear at 220 cm/s. Both feet are planted side by side from ``"gather"`` to
    ``"takeoff"`` and again from ``"landing"`` until the walk out.
    """
    _check(duration=duration)
    if duration < 4.0:
        raise ValueError(f"duration must be at least 4 s for the jump, got {duration!r}")
    J = JUMP_TIMES
    t = _times(duration)
    T, v = 1.1, 100.0
    # gait phase: left stance centred at w = 0 (mod 2 pi); the walk out restarts the phase
    w = 2.0 * np.pi * np.where(t < 3.0, t, t - 3.5) / T
    t_to, t_ld = J["takeoff"], J["landing"]
    tf = t_ld - t_to
    vy0 = 0.5 * GRAVITY * tf
    # forward travel: (time, z, dz/dt) keys; Hermite reproduces the straight line of the flight
    z_to = 204.5
    z_ld = z_to + _JUMP_VZ * tf
    zkeys = [(-2.0, -200.0, v), (1.3, 130.0, v), (2.1, 166.0, 0.0), (t_to, z_to, _JUMP_VZ),
             (t_ld, z_ld, _JUMP_VZ), (3.25, z_ld + 0.35 * 0.5 * _JUMP_VZ, 0.0),
             (3.5, z_ld + 0.35 * 0.5 * _JUMP_VZ, 0.0), (4.2, z_ld + 38.5 + 35.0, v), (duration + 3.0, 0.0, v)]
    zkeys[-1] = (duration + 3.0, zkeys[-2][1] + v * (duration + 3.0 - 4.2), v)
    root_z = lambda tt: _hermite(zkeys, np.asarray(tt, dtype=float))  # noqa: E731
    # feet: walk-in steps, both feet gathered for the jump, landing side by side, walk-out steps
    L_on, L_off, L_xz = [], [], []
    R_on, R_off, R_xz = [], [], []
    half = 0.3 * T
    for tc in (-2.2, -1.1, 0.0, 1.1):
        L_on.append(tc - half), L_off.append(tc + half), L_xz.append((_FOOT_X, float(root_z(tc))))
    for tc in (-1.65, -0.55, 0.55):
        R_on.append(tc - half), R_off.append(tc + half), R_xz.append((-_FOOT_X, float(root_z(tc))))
    z_feet = 172.0
    R_on.append(1.65 - half), R_off.append(t_to), R_xz.append((-_FOOT_X, z_feet))
    L_on.append(J["gather"]), L_off.append(t_to), L_xz.append((_FOOT_X, z_feet))
    z_land = z_ld + 29.0
    L_on.append(t_ld), L_off.append(3.95), L_xz.append((_FOOT_X, z_land))
    R_on.append(t_ld), R_off.append(3.5), R_xz.append((-_FOOT_X, z_land))
    for tc in np.arange(4.05, duration + 2.5, T):
        R_on.append(tc - half), R_off.append(tc + half), R_xz.append((-_FOOT_X, float(root_z(tc))))
        tl = tc + 0.5 * T
        L_on.append(tl - half), L_off.append(tl + half), L_xz.append((_FOOT_X, float(root_z(tl))))
    # tuck the feet in flight: the swing after the take-off plant lifts higher
    lp = _Plants(L_on, L_off, L_xz, [25.0 if off == t_to else 9.0 for off in L_off])
    rp = _Plants(R_on, R_off, R_xz, [25.0 if off == t_to else 9.0 for off in R_off])
    walking = 1.0 - _smoothstep(t, 1.45, 1.8) + _smoothstep(t, 3.6, 4.2)
    # root height: walk bob where walking, Hermite keys through crouch, exact parabola in flight
    ykeys = [(-2.0, 94.0, 0.0), (1.6, 94.0, 0.0), (J["crouch"], 70.0, 0.0), (t_to, 90.0, vy0), (t_ld, 90.0, -vy0),
             (J["absorb"], 72.0, 0.0), (3.6, 94.0, 0.0), (duration + 3.0, 94.0, 0.0)]
    root_y = _hermite(ykeys, t) + walking * 1.5 * np.cos(2.0 * w)
    root_xz = np.stack([2.0 * walking * np.cos(w), root_z(t)], -1)
    lean = _hermite([(-2.0, 0, 0), (1.7, 0, 0), (J["crouch"], 25.0, 0), (t_to, 8.0, 0), (t_ld, 6.0, 0),
                     (J["absorb"], 22.0, 0), (3.7, 0, 0), (duration + 3.0, 0, 0)], t)
    p_yaw, p_roll, s_yaw, s_roll, arm, d_elbow = _gait_upper(w, 0.6, twist=6.0, roll=3.0, arm=22.0,
                                                              elbow=10.0, lag=0.35, weight=walking)
    pelvis = np.stack([p_yaw, 3.0 + 0.6 * lean, p_roll], -1)
    spine = np.stack([s_yaw, 2.0 + lean, s_roll], -1)
    head = np.stack([np.zeros_like(t), -0.5 * lean], -1)
    reach = _hermite([(-2.0, 0, 0), (1.7, 0, 0), (J["crouch"], -35.0, 0), (t_to, 100.0, 0), (t_ld, 50.0, 0),
                      (3.5, 0, 0), (duration + 3.0, 0, 0)], t)
    arm = arm + reach[:, None]
    elbow = 18.0 + d_elbow
    return _build(t, root_xz, root_y, pelvis, spine, head, arm, elbow, (lp, rp), seed, 0.6, return_contacts)


def _check(**kw):
    for k, v in kw.items():
        if not np.isfinite(v) or v <= 0:
            raise ValueError(f"{k} must be a positive number, got {v!r}")


CLIPS = {"walk": walk, "run": run, "jump": jump}


def generate(name: str, return_contacts: bool = False):
    """The procedural clip ``name`` (one of :data:`CLIPS`) with its default, deterministic settings
    (and its foot-contact masks if ``return_contacts``)."""
    try:
        return CLIPS[name](return_contacts=return_contacts)
    except KeyError:
        raise ValueError(f"name must be one of {sorted(CLIPS)}, got {name!r}") from None
