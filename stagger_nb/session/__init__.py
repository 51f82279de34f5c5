"""Edit sessions: a source motion plus an ordered list of JSON-serialisable operations.

An *op* is a plain dict such as ``{"op": "succession", "root": "LeftShoulder", "s": 0.03, "l": 2.0}``;
inside the session it is a typed frozen dataclass (:mod:`.ops`). Replaying the ops in order on the source
motion gives the edited motion; this is what makes a notebook's edits reproducible (DESIGN.md, "session").
The state flowing through the ops is a :class:`~stagger_nb.core.Motion` or a staggered-pose representation
(``staggered.StaggeredMotion``): staggered ops extract first (Coleman et al. 2008, §4; the extraction is
cached), motion ops evaluate first (§3).

One module per job:

- :mod:`.session` — :class:`Session`: the op list and history, the replay's entry points, warm-up, files;
- :mod:`.heads` — the expensive heads of the techniques, each computed once (:class:`~.heads.Heads`), and the
  session's methods over them (culls, the wand's basis and falloffs, forward kinematics);
- :mod:`.replay` — the replay: chained prefix digests, each state computed once, the per-step notes;
- :mod:`.ops` — one frozen dataclass per op (:mod:`.ops.staggered`, :mod:`.ops.motion`), ``from_json`` /
  ``to_json``, every field checked (:mod:`.ops.fields`), the limits (:func:`~.ops.limits`);
- :mod:`.runners` — op -> function over the state: the staggered ops' (:mod:`.runners`), the motion ops' and the
  warps' (:mod:`.motion_runners`), what they share (:mod:`.run`: ``Run``, ``convert``);
- :mod:`.history` — the op list, undo/redo, observers;
- :mod:`.cache` — the one cache (one lock, compute-once futures, content/weakref keys, bounded);
- :mod:`.files` — save/load/export and the JSON motion format, with the path and overwrite guards;
- :mod:`.warm` — the session's background worker for :meth:`Session.warm` and the next slider step (``next_step``);
- :mod:`.warp_steps` — a guided warp's duration slider: the searches of its likely next lengths, in the background;
- :mod:`.progress` — :func:`progress_bar`, a tqdm bar as the ``progress`` callback of ``edited``/``warm``;
- :mod:`.timeline` — the dope sheet's rows and marks of a staggered state;
- :mod:`.models` — the editors' evented models and the binding that keeps one in step with a session.

This package does not import ipywidgets; the widgets build on it.
"""
from __future__ import annotations

import warnings

from .deprecated import register_op
from .files import SESSION_FORMAT, SESSION_VERSION
from .ops import OPS, Op, validate_op
from .progress import ProgressBar, progress_bar
from .replay import ReplayError
from .runners import apply_pose_deltas, warp_table_key
from .session import Session, joint_rotation_degrees

__all__ = ["Session", "Op", "OPS", "validate_op", "apply_pose_deltas", "joint_rotation_degrees",
           "SESSION_FORMAT", "SESSION_VERSION", "progress_bar", "ProgressBar", "register_op", "warp_table_key",
           "ReplayError"]


def __getattr__(attr):  # deprecated module attributes
    if attr == "OP_REGISTRY":
        warnings.warn("OP_REGISTRY is deprecated: use stagger_nb.session.OPS (op classes by name)",
                      DeprecationWarning, stacklevel=2)
        return OPS
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")
