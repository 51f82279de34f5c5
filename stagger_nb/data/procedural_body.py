"""The body solver shared by the procedural clips (:mod:`.procedural`): analytic two-bone leg IK, the root
height softly limited so planted ankles stay in reach, the upper body's gait signals, and the assembly of
one :class:`~stagger_nb.core.motion.Motion` from a root trajectory, foot plants and body curves
(:func:`_build`)."""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.motion import Motion
from ..core.rotations import euler_to_quat, quat_conj, quat_mul, quat_rotate
from .procedural_curves import _noise, _softmin
from .procedural_rig import _ARM_HANG, _HIP, _REACH, FPS, SHIN, THIGH, cmu_skeleton


def _euler(order: str, deg: np.ndarray) -> np.ndarray:
    """Intrinsic Euler angles in degrees (F, 3) -> quaternions (F, 4) (the package's one conversion)."""
    return euler_to_quat(np.asarray(deg, dtype=float), order)


def _axis_quat(axis: str, deg: np.ndarray) -> np.ndarray:
    """Rotation about one axis by ``deg (F,)`` degrees -> (F, 4)."""
    return euler_to_quat(np.asarray(deg, dtype=float).reshape(-1, 1), axis)



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

