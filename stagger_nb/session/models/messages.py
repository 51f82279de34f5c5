"""Plain sentences for what an editor shows when a change cannot apply: no op index, no exception name, no
raw numpy text; what failed, in the editor's words, and why.

:func:`plain_message` turns a session's ``ValueError`` (a malformed op, ``ops[2].s: expected ...``) or a
:class:`~stagger_nb.session.ReplayError` (an op failing at replay) into such a sentence.
"""
from __future__ import annotations

import re

from ..replay import ReplayError

__all__ = ["plain_message", "describe_op"]

#: How an editor names each op in a message ({field} from the op).
_OP_WORDS = {
    "extract": "the pose extraction", "cull": "the cull", "succession": "the succession",
    "random_timing": "the random timing", "exaggerate": "the exaggeration",
    "edit_pose": "the edit of pose {pose}", "retime": "moving pose {pose} to {time:.3f} s",
    "insert_pose": "inserting a pose at {time:.3f} s", "delete_pose": "deleting pose {pose}",
    "keep_contacts": "keeping the foot contacts", "ik_pose": "the IK target of {joint} at pose {pose}",
    "edit_frame": "the edit of frame {frame}", "propagate": "the magic-wand edit",
    "guided_warp": "the guided time warp", "linear_warp": "the linear time warp", "resample": "the resampling",
}

#: Technique or numpy texts a person should not have to read, and what they mean here.
_RAW = [
    (re.compile(r"zero-size array to reduction operation \w+( which has no identity)?"),
     "no frames or poses are left to work on"),
    (re.compile(r"targets: each must be 3 finite numbers or \(\d+, 3\), got shape \(\d*,? ?\d*\)"),
     "a held foot contact would have to move to a place that is not a finite position"),
    (re.compile(r"pose_times must be strictly increasing"), "the poses would no longer follow one another in time"),
    (re.compile(r"must be finite \(no NaN / inf\)|must be finite, non-zero quaternions"),
     "the result would not be a finite motion"),
    (re.compile(r"math domain error"), "a value is outside what the computation can take"),
]
_PREFIX = re.compile(r"^ops\[\d+\](\.| \([a-z_]+\): )")
_EXCEPTION = re.compile(r"\b[A-Z][A-Za-z]*(Error|Exception|Warning): ")


def describe_op(op) -> str:
    """The editor's words for ``op`` (a typed op or its JSON dict), e.g. "moving pose 2 to 0.410 s"."""
    data = op if isinstance(op, dict) else op.to_json()
    words = _OP_WORDS.get(data.get("op"), f"the {data.get('op')} edit")
    try:
        return words.format(**{k: v for k, v in data.items() if k != "op"})
    except (KeyError, ValueError, TypeError, IndexError):
        return words.split(" {")[0].replace("{", "").replace("}", "")


def _clean(text: str) -> str:
    text = _EXCEPTION.sub("", _PREFIX.sub("", text.strip()))
    for pattern, plain in _RAW:
        text = pattern.sub(plain, text)
    return text.rstrip(".")


#: a pose-indexed edit whose pose the staggered state no longer has (run.py's pose check)
_POSE_GONE = re.compile(r"^pose: (\d+) is outside the (\d+) poses$")


def plain_message(error: Exception) -> str:
    """One plain sentence for ``error``: for a :class:`ReplayError` "<the op, in words> cannot be applied:
    <why>", for another error its text without the op index and exception names. An edit of a pose the cull
    no longer keeps (a cull to 10 poses under an IK target at pose 10) says what to do: keep more poses, or
    undo or remove that edit first."""
    if isinstance(error, ReplayError):
        cause = _clean(error.cause)
        gone = _POSE_GONE.match(cause)
        if gone:
            k, n = (int(x) for x in gone.groups())
            return (f"{describe_op(error.op)} would be lost: only {n} poses would be left (0 to {n - 1}); "
                    f"keep {k + 1} poses or more, or undo or remove that edit first")
        return f"{describe_op(error.op)} cannot be applied: {cause}"
    return _clean(str(error))
