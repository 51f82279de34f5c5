"""CMU / Acclaim ASF (skeleton) + AMC (motion) reader.

The Acclaim model (column vectors; ``Rx``, ``Ry``, ``Rz`` the elementary rotations):

* each bone ``b`` has a rest direction ``d_b`` (unit vector, world frame), a ``length`` and an
  ``axis a1 a2 a3 ORDER`` line giving its local frame ``C_b = R_ORDER[2](a3) R_ORDER[1](a2) R_ORDER[0](a1)``
  (the first listed axis is applied first; ``axis 0 0 20 XYZ`` is ``Rz(20) Ry(0) Rx(0)``);
* an AMC frame gives values for the bone's ``dof`` (e.g. ``rx ry rz``), composed the same way:
  ``M_b = ... R_dof2 R_dof1`` (first listed dof applied first);
* the bone's world rotation is ``W_b = W_parent C_b M_b C_b^-1`` and its end point is
  ``e_b = e_parent + W_b (length_b * d_b)``; the root's ``W_root = C_root M_root C_root^-1`` with
  ``C_root`` from ``:root orientation`` / ``axis`` and ``M_root`` from the root's rotation channels,
  and ``e_root`` is the root's translation channels (``TX TY TZ``).

Conversion to :class:`~stagger_nb.core.Motion`: one joint ``"root"`` plus one joint per bone, in
depth-first hierarchy order. The joint of bone ``b`` sits at the bone's start (its parent's end), so
its OFFSET is the parent bone's vector ``length_p * d_p`` (zero below the root), a leaf bone gets an
``End Site`` at its own vector, and the rest pose has identity rotations everywhere. The local rotation
of joint ``b`` is then ``C_b M_b C_b^-1``. Channels are laid out for BVH writing as
``Zrotation Yrotation Xrotation`` (= ``Rz Ry Rx``, the CMU convention), the root adding
``Xposition Yposition Zposition`` first.

Units: lengths and root translations are kept in file units by default (as the common CMU BVH
conversions do); ``units="inches"`` or ``"meters"`` rescale using ``:units length L`` (CMU: file
length = inches * L). Angles follow ``:units angle deg|rad`` (AMC ``:DEGREES`` / ``:RADIANS`` override
for the motion file).

The text is read by :mod:`.asf_read` (:func:`parse_asf`) and :mod:`.amc_read` (:func:`parse_amc`); this module
builds the :class:`Motion` from what they parse (:func:`asf_amc_to_motion`) and reads a pair of files.
"""
from __future__ import annotations

import numpy as np

from ..core.motion import Motion, check_frame_time
from ..core.rotations import quat_conj, quat_mul
from ..core.skeleton import Skeleton
from ._common import euler_deg_to_quat, file_path, read_text
from .amc_read import parse_amc
from .asf_read import AMCError, AsfSkeleton, parse_asf

__all__ = ["AMCError", "read_asf_amc", "parse_asf", "parse_amc", "AsfSkeleton"]

_UNIT_SCALE = {"file": None, "inches": 1.0, "meters": 0.0254}


def _compose(axes: str, angles_deg) -> np.ndarray:
    """Acclaim composition ``R_axes[-1] ... R_axes[0]`` (first listed axis applied first, i.e. extrinsic)
    of angles in degrees ``(..., len(axes))`` -> quaternions ``(..., 4)`` (x, y, z, w)."""
    return euler_deg_to_quat(np.asarray(angles_deg, dtype=float)[..., ::-1], axes[::-1])


def _conjugate_by(c: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``C M C^-1`` for a quaternion ``c (4,)`` and ``m (F, 4)``."""
    return quat_mul(quat_mul(c, m), quat_conj(c))


def asf_amc_to_motion(asf: AsfSkeleton, root: np.ndarray, dofs: list, frame_time: float,
                      units: str = "file") -> Motion:
    """Build the :class:`Motion` described in the module docstring from parsed ASF/AMC arrays."""
    if units not in _UNIT_SCALE:
        raise ValueError(f"units must be one of {', '.join(_UNIT_SCALE)}, got {units!r}")
    s = 1.0 if _UNIT_SCALE[units] is None else _UNIT_SCALE[units] / asf.length_scale
    F = root.shape[0]
    B = len(asf.bones)
    vec = np.array([b.direction * b.length for b in asf.bones]).reshape(B, 3) * s
    names = ["root"] + [b.name for b in asf.bones]
    parents = np.array([-1] + [p + 1 for p in asf.parents])
    offsets = np.zeros((B + 1, 3))
    has_child = np.zeros(B + 1, dtype=bool)
    for k, p in enumerate(asf.parents):
        j = k + 1
        if p >= 0:
            offsets[j] = vec[p]
        has_child[p + 1] = True
    end_sites = {k + 1: vec[k] for k in range(B) if not has_child[k + 1]}
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
               [("Zrotation", "Yrotation", "Xrotation")] * B
    skel = Skeleton(names, parents, offsets, tuple(channels), end_sites)

    quats = np.empty((F, B + 1, 4))
    # root
    c_root = _compose(asf.root_axis, asf.root_orientation)
    rot_idx = [i for i, t in enumerate(asf.root_order) if t.startswith("r")]
    rot_axes = "".join(asf.root_order[i][1] for i in rot_idx)
    m_root = _compose(rot_axes, root[:, rot_idx])
    quats[:, 0] = _conjugate_by(c_root, m_root)
    pos = np.broadcast_to(asf.root_position * s, (F, 3)).copy()
    for i, t in enumerate(asf.root_order):
        if t.startswith("t"):
            pos[:, "xyz".index(t[1])] = root[:, i] * s
    for k, b in enumerate(asf.bones):
        c = _compose(b.axis_order, np.array(b.axis_angles))
        if b.dof:
            m = _compose("".join(d[1] for d in b.dof), dofs[k])
            quats[:, k + 1] = _conjugate_by(c, m)
        else:
            quats[:, k + 1] = [0.0, 0.0, 0.0, 1.0]
    return Motion(skel, frame_time, pos, quats)


def read_asf_amc(asf_path, amc_path, frame_time: float = 1 / 120, units: str = "file") -> Motion:
    """Read a CMU/Acclaim skeleton (``.asf``) and motion (``.amc``) into a :class:`Motion`.

    Parameters
    ----------
    asf_path, amc_path : path-like
    frame_time : float
        Seconds between AMC frames (AMC files do not store it; CMU captured at 120 Hz).
    units : {"file", "inches", "meters"}
        ``"file"`` keeps the ASF's units (CMU: inches * 0.45, as the usual CMU BVH conversions do).

    Returns
    -------
    Motion
        ``root_positions (F, 3)``, ``local_quats (F, 1 + bones, 4)`` (x, y, z, w); joint 0 is
        ``"root"``, the others are the ASF bones in depth-first order (see the module docstring).

    Raises
    ------
    AMCError
        (a ``ValueError``) naming the file, line and what was expected, for malformed input.
    ValueError
        For a bad ``frame_time`` or ``units``.
    """
    ft = check_frame_time(frame_time)
    if units not in _UNIT_SCALE:
        raise ValueError(f"units must be one of {', '.join(_UNIT_SCALE)}, got {units!r}")
    asf_path, amc_path = file_path(asf_path, "asf_path"), file_path(amc_path, "amc_path")
    asf = parse_asf(read_text(asf_path, AMCError), asf_path)
    root, dofs = parse_amc(read_text(amc_path, AMCError), asf, amc_path)
    return asf_amc_to_motion(asf, root, dofs, ft, units)
