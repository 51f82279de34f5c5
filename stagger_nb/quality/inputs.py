"""The checks of :func:`~stagger_nb.quality.compare`'s and :func:`~stagger_nb.quality.prepare`'s arguments (each
error names the parameter)."""
from __future__ import annotations

import numpy as np

from ..core.kinematics import _to_component_major
from ..core.motion import Motion


def _as_motion(x, name: str):
    """(Motion, StaggeredMotion or None) of a compare() argument."""
    from ..staggered import StaggeredMotion, evaluate
    if isinstance(x, StaggeredMotion):
        return evaluate(x), x
    if isinstance(x, Motion):
        return x, None
    raise ValueError(f"{name} must be a Motion or a StaggeredMotion, got {type(x).__name__}")


def _same_rig(source: Motion, other, name: str) -> None:
    a, b = source.skeleton, other.skeleton
    if a.names != b.names or not np.array_equal(a.parents, b.parents):
        diff = next((f"joint {i}: {x!r} vs {y!r}" for i, (x, y) in enumerate(zip(a.names, b.names)) if x != y),
                    f"{a.num_joints} vs {b.num_joints} joints" if a.num_joints != b.num_joints else "parents differ")
        raise ValueError(f"{name} must have the source's skeleton ({diff})")


def _finite_motion(m: Motion, name: str) -> None:
    for attr in ("local_quats", "root_positions", "local_translations"):
        a = getattr(m, attr)
        if a is not None and not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: {attr} must be finite (no NaN / inf)")


def _check_contacts(source: Motion, contacts) -> tuple:
    out = []
    names = source.skeleton.names
    for i, item in enumerate(contacts):
        try:
            name, a, b = item
            a, b = int(a), int(b)
        except (TypeError, ValueError):
            raise ValueError(f"contacts[{i}]: must be (joint_name, start_frame, stop_frame), got {item!r}") from None
        if isinstance(name, (int, np.integer)) and 0 <= int(name) < len(names):
            name = names[int(name)]
        if name not in names:
            raise ValueError(f"contacts[{i}]: unknown joint {name!r}")
        if not 0 <= a < b <= source.num_frames:
            raise ValueError(f"contacts[{i}]: frames [{a}, {b}) of {name!r} must lie in [0, {source.num_frames}) "
                             "and be non-empty")
        out.append((str(name), a, b))
    return tuple(out)


def _positions_arg(x, motion: Motion, name: str) -> np.ndarray:
    """``x`` (F, J, 3) checked as ``forward_kinematics(motion)[0]``'s shape and finite, component-major."""
    p = np.asarray(x, dtype=float)
    want = (motion.num_frames, motion.num_joints, 3)
    if p.shape != want or not np.all(np.isfinite(p)):
        raise ValueError(f"{name} must be finite, of shape {want} (forward_kinematics(...)[0]), got {p.shape}")
    return _to_component_major(p)
