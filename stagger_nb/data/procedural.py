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

The rig and its measures are in :mod:`.procedural_rig`, the curves and foot plants of steps 1-2 in
:mod:`.procedural_curves`, the body solver of steps 3-5 in :mod:`.procedural_body`; this module blocks the
three clips.
"""
from __future__ import annotations

import numpy as np

from .procedural_body import _build, _gait_upper
from .procedural_curves import _cycle_plants, _hermite, _Plants, _smoothstep
from .procedural_rig import _FOOT_X, ANKLE_HEIGHT, FPS, GRAVITY, SHIN, THIGH, cmu_skeleton

__all__ = ["cmu_skeleton", "walk", "run", "jump", "generate", "CLIPS", "FPS", "GRAVITY",
           "THIGH", "SHIN", "ANKLE_HEIGHT"]


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
