"""The source's part of :func:`~stagger_nb.quality.compare`, computed once: :func:`prepare` and its
:class:`SourceFigures`."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.body import pelvis_joint, up_axis
from ..core.kinematics import _to_component_major, _to_frame_major
from ..core.motion import Motion
from .arrays import (
    _band_pass_energy,
    _detail_kernel,
    _detail_step,
    _fk_cm,
    _height_rows,
    _relative_rotvecs,
    _step_angles,
    _step_lengths,
)
from .body import _body_height
from .bounds import _positive
from .constants import BODY_CM
from .inputs import _check_contacts, _finite_motion, _positions_arg


@dataclass(frozen=True, eq=False)
class SourceFigures:
    """Everything :func:`compare` reads of the source alone, computed once by :func:`prepare` (read-only
    arrays; a session caches one per source). Pass it as ``compare(source, edited, prepared=...)``: the
    figures are the same, bit for bit, as without it.

    Attributes
    ----------
    source : Motion
        The motion these figures are of (``compare`` checks it is the ``source`` it is given).
    positions : ndarray, shape (F, J, 3)
        ``forward_kinematics(source)[0]``, file units.
    up : ndarray, shape (3,)
        The vertical axis (:func:`~stagger_nb.core.body.up_axis`).
    body_height, scale : float
        :func:`body_height` (file units) and ``BODY_CM / body_height``.
    contacts : tuple of (joint_name, start_frame, stop_frame)
        The source's contacts (default :func:`~stagger_nb.staggered.detect_contacts`), half-open frames.
    floor : float
        The lowest height any joint of the source reaches (file units).
    pelvis : int
        :func:`~stagger_nb.core.body.pelvis_joint`.
    step_angles : ndarray, shape (J,)
        Each joint's largest frame-to-frame rotation (degrees).
    step_lengths : ndarray, shape (J,)
        Each joint's largest frame-to-frame displacement (file units).
    velocity : ndarray, shape (3, J, G - 1)
        Local angular velocity on the detail grid (G samples ``h`` apart, see :mod:`stagger_nb.quality`):
        ``rotvec(q(n)⁻¹ q(n+1)) / h`` (rad/s), component-major.
    detail : ndarray, shape (J,)
        Band-passed energy of ``velocity`` over the whole grid (rad²/s²).
    """

    source: Motion
    positions: np.ndarray
    up: np.ndarray
    body_height: float
    scale: float
    contacts: tuple
    floor: float
    pelvis: int
    step_angles: np.ndarray
    step_lengths: np.ndarray
    velocity: np.ndarray
    detail: np.ndarray
    _P: np.ndarray = field(repr=False, default=None)          # positions, component-major (3, J, F)
    _Q: np.ndarray = field(repr=False, default=None)          # local rotations, component-major (4, J, F)
    _kernel: np.ndarray = field(repr=False, default=None)     # the detail band-pass (see _detail_kernel)
    _step: int = field(repr=False, default=1)                 # source frames per detail sample (_detail_step)

    def __repr__(self) -> str:
        return (f"SourceFigures({self.source.num_frames} frames x {self.source.num_joints} joints, body "
                f"{self.body_height:.4g} units, {len(self.contacts)} contacts)")


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def prepare(source: Motion, *, contacts=None, body_height: float | None = None,
            source_positions: np.ndarray | None = None) -> SourceFigures:
    """The figures of ``source`` that :func:`compare` needs for any edit (its FK, contacts, body height,
    floor, per-joint largest frame-to-frame rotation and displacement, angular velocity and its detail
    energy), computed once: ``compare(source, edited, prepared=prepare(source))`` then measures only the
    edit (one FK of the edited motion, or none with ``edited_positions=``).

    Parameters are those of :func:`compare` of the same names (``contacts`` default
    :func:`~stagger_nb.staggered.detect_contacts`; ``body_height`` default :func:`body_height`;
    ``source_positions``: ``forward_kinematics(source)[0]`` when the caller has it). Returns a frozen
    :class:`SourceFigures`.
    """
    from .. import staggered as stg
    if not isinstance(source, Motion):
        raise ValueError(f"source must be a Motion, got {type(source).__name__}")
    _finite_motion(source, "source")
    if source_positions is None:
        P, Q = _fk_cm(source)
    else:
        P, Q = _positions_arg(source_positions, source, "source_positions"), _to_component_major(source.local_quats)
    pos = _readonly(_to_frame_major(P))
    up = up_axis(source, pos)
    h_body = _body_height(source, pos) if body_height is None else _positive(body_height, "body_height")
    if contacts is None:
        contacts = stg.detect_contacts(source, positions=pos)
    contacts = _check_contacts(source, contacts)
    step = _detail_step(source.frame_time)
    h = step * source.frame_time
    Qg = Q[:, :, ::step]
    V = (_relative_rotvecs(Qg[:, :, :-1], Qg[:, :, 1:]) / h if Qg.shape[2] > 1
         else np.zeros((3, source.num_joints, 0)))
    kernel = _detail_kernel(h)
    detail = _band_pass_energy(V, kernel) if Qg.shape[2] >= 3 else np.zeros(source.num_joints)
    return SourceFigures(
        source=source, positions=pos, up=_readonly(up), body_height=h_body, scale=BODY_CM / h_body,
        contacts=contacts, floor=float(_height_rows(P, up).min()), pelvis=pelvis_joint(source.skeleton),
        step_angles=_readonly(_step_angles(Q)), step_lengths=_readonly(_step_lengths(P)),
        velocity=_readonly(V), detail=_readonly(detail), _P=_readonly(P), _Q=_readonly(Q), _kernel=_readonly(kernel),
        _step=step)
