"""One knot at a time: the timing refinement of one joint at one staggered pose (Coleman et al. 2008, §3, §5.2).

A staggered pose ``k`` has, for every joint ``j``, a knot at the *refined time* ``T[k, j] = t_k + r[k, j]``
(§3: "the equivalent knot in a traditional spline representation is (t_k + r_{k,i}, v_{k,i})"). Succession and
random timing (§5.2) move many knots by a formula; :func:`refine` moves one, to a time the user chose (the
dope sheet's drag). Like the other temporal edits it changes only ``r[k, j]``: the splines and displacement
maps live on normalised segment time and follow, the editing knot ``v⁰[k, j]`` (the true pose at ``t_k``) is
re-created by evaluation.
"""
from __future__ import annotations

import numpy as np

from .editing import _check, _finite, _joint_mask, _pose_index, _with_timing
from .representation import StaggeredMotion

__all__ = ["refine"]


def refine(sm: StaggeredMotion, pose: int, joint, time: float) -> StaggeredMotion:
    """Put joint ``joint``'s knot of pose ``pose`` at the refined time ``time`` seconds: ``r[k, j] = time - t_k``.

    The knot must stay strictly between the same joint's knots of the neighbouring poses (``T[k - 1, j] < time
    < T[k + 1, j]``): a knot past its neighbour would reverse that joint's motion between them. The first and
    last poses are the clip's first and last frames (§4.1) and keep their knots. The root joint's knot moves
    its translation's knot by the same amount (both are the root's timing, as in :func:`succession`), which
    must then stay in order too.

    Parameters
    ----------
    sm : StaggeredMotion
    pose : int, an interior pose index (0 < pose < K - 1; negative indices count from the end)
    joint : str or int, joint name or index
    time : float, seconds, the knot's new refined time ``t_k + r[k, j]``

    Returns
    -------
    StaggeredMotion (``sm`` itself when the knot is already there).

    Raises
    ------
    ValueError naming the parameter: an unknown joint or pose, an end pose, a time that is not finite or
    would leave the knots out of order (the message gives the open interval the knot may move in).
    """
    _check(sm)
    k = _pose_index(sm, pose, "pose")
    mask = _joint_mask(sm, [joint])
    j = int(mask.argmax())
    time = _finite(time, "time")
    K = sm.num_poses
    name = sm.skeleton.names[j]
    if k in (0, K - 1):
        raise ValueError(f"pose: pose {k} is the clip's {'first' if k == 0 else 'last'} frame; its knots stay at "
                         f"{sm.pose_times[k]:.3f} s (retime an interior pose, or the pose as a whole)")
    knots = sm.pose_times + sm.refinements[:, j]
    lo, hi = float(knots[k - 1]), float(knots[k + 1])
    if not lo < time < hi:
        raise ValueError(f"time: {name}'s knot of pose {k} must stay between its knots of poses {k - 1} and {k + 1}, "
                         f"{lo:.3f} s < time < {hi:.3f} s; got {time:.3f} s")
    d = time - float(knots[k])
    if j == 0:
        rk = sm.pose_times + sm.root_refinements
        lo_r, hi_r, at = float(rk[k - 1]), float(rk[k + 1]), float(rk[k]) + d
        if not lo_r < at < hi_r:
            raise ValueError(f"time: the root translation's knot of pose {k} would move to {at:.3f} s, outside "
                             f"its neighbours' {lo_r:.3f} s .. {hi_r:.3f} s")
    dr = np.zeros((K, sm.num_joints))
    dr[k, j] = d
    return _with_timing(sm, dr, mask)
