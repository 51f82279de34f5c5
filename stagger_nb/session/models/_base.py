"""What the three editor models share: the playhead, the joint names, the message, validators.

Validators raise ``traitlets.TraitError`` with a message naming the trait (as ``ValueError`` does elsewhere).
"""
from __future__ import annotations

import contextlib
import copy
import json
import math

import traitlets as T

__all__ = ["_Model"]


def _canon(x) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"), default=str)


def _finite(name: str, v) -> float:
    v = float(v)
    if not math.isfinite(v):
        raise T.TraitError(f"{name}: expected a finite number, got {v!r}")
    return v


def _deltas3(name: str, d) -> dict:
    if not isinstance(d, dict):
        raise T.TraitError(f"{name}: expected {{joint: [rx, ry, rz] degrees}}, got {d!r}")
    out = {}
    for j, v in d.items():
        if not isinstance(j, str) or not isinstance(v, (list, tuple)) or len(v) != 3:
            raise T.TraitError(f"{name}.{j}: expected [rx, ry, rz] degrees, got {v!r}")
        out[j] = [_finite(f"{name}.{j}", x) for x in v]
    return out


class _Model(T.HasTraits):
    """Common traits: the playhead, the names the model knows, and the plain-text message."""

    frame = T.Int(0, help="the playhead: frame index (0-based) shown by the 3D view and every time plot")
    joint_names = T.List(T.Unicode(), help="joint names of the source skeleton (set by the binding)")
    message = T.Unicode("", help="plain-text note about the parameters ('' when none): a refused value, an "
                                 "op naming a joint this skeleton does not have")

    num_frames = T.Int(0, help="frames of the edited motion the playhead moves over (set by the editor when "
                               "it shows a new edit; 0 = unknown)")

    @T.validate("frame")
    def _v_frame(self, proposal):
        if proposal["value"] < 0 or 0 < self.num_frames <= proposal["value"]:
            top = f" and < {self.num_frames} (the edited motion's frames)" if self.num_frames else ""
            raise T.TraitError(f"frame: expected an index >= 0{top}, got {proposal['value']}")
        return proposal["value"]

    def _known_joint(self, field: str, name) -> str:
        """``name`` if this skeleton has it (or the names are not known yet), else a TraitError naming ``field``."""
        if not isinstance(name, str):
            raise T.TraitError(f"{field}: expected a joint name, got {name!r}")
        if self.joint_names and name not in self.joint_names:
            raise T.TraitError(f"{field}: no joint named {name!r} in this skeleton")
        return name

    def _index_below(self, field: str, k, n: int, what: str) -> int:
        """``k`` as an int if ``0 <= k < n`` (``n`` = 0: not known yet), else a TraitError naming ``field``."""
        k = int(k)
        if k < 0 or 0 < n <= k:
            raise T.TraitError(f"{field}: {k} is outside the {n} {what}" if k >= 0 else
                               f"{field}: expected an index >= 0, got {k}")
        return k

    def _edits_at(self, field: str, value: dict, n: int, what: str, held=()) -> dict:
        """``{index: {joint: [rx, ry, rz]}}`` validated: each index below ``n`` (indices in ``held`` are not
        re-checked), each joint known, each rotation three finite degrees."""
        out = {}
        for k, v in value.items():
            k = int(k) if int(k) in held else self._index_below(field, k, n, what)
            out[k] = _deltas3(f"{field}[{k}]", v)
            for j in out[k]:
                self._known_joint(f"{field}[{k}]", j)
        return out

    def _seek(self, frame: int) -> None:
        """Move the playhead to ``frame`` as the model itself does (a pose's or an edited frame's time, which may
        lie past a shorter warped edit): clamped to the edited motion, never refused."""
        self.frame = min(int(frame), self.num_frames - 1) if self.num_frames else int(frame)

    @T.observe("num_frames")
    def _keep_frame_inside(self, change):
        if 0 < change["new"] <= self.frame:   # a shorter edit (a warp): the playhead moves to its last frame
            self.frame = change["new"] - 1

    _loading = False

    @contextlib.contextmanager
    def loading(self):
        """Set traits as a load (from the session), not as a user edit: observers that turn a user's move
        into an edit (moving an edited frame, recording an IK target) stand still."""
        old, self._loading = self._loading, True
        try:
            yield self
        finally:
            self._loading = old

    def params(self) -> dict:
        """The op parameters (traits tagged ``op=True``) as a plain dict (deep copy)."""
        return {k: copy.deepcopy(getattr(self, k)) for k in self.trait_names(op=True)}
