"""Small hand-built motions and checks shared by several test modules (tests import them from here, not from each
other)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from stagger_nb.core.motion import Motion
from stagger_nb.core.rotations import rotvec_to_quat
from stagger_nb.core.skeleton import Skeleton
from stagger_nb.session import Session

__all__ = ["chain_motion", "assert_load_names_the_field", "assert_refuses_the_source"]


def chain_motion(reverse_times, duration=2.0, fps=120.0, amplitude=1.0, span=1.0):
    """Root + len-1 joints in a chain along +y (offset 1 each, End Site on the last); joint i rotates about
    z by ``amplitude * (1 - ((t - t_i) / span)^2)``, which reverses direction exactly at ``t_i``. The root
    does not translate."""
    J = len(reverse_times)
    names = ["Root"] + [f"J{i}" for i in range(1, J)]
    parents = np.arange(-1, J - 1)
    offsets = np.zeros((J, 3))
    offsets[1:, 1] = 1.0
    sk = Skeleton(names, parents, offsets, end_sites={J - 1: np.array([0.0, 1.0, 0.0])})
    t = np.arange(int(round(duration * fps)) + 1) / fps
    ang = amplitude * (1.0 - ((t[:, None] - np.asarray(reverse_times)[None]) / span) ** 2)
    rv = np.zeros(ang.shape + (3,))
    rv[..., 2] = ang
    return Motion(sk, 1.0 / fps, np.zeros((t.size, 3)), rotvec_to_quat(rv))


def assert_load_names_the_field(path, mutate, field: str) -> None:
    """Apply ``mutate`` to the JSON of the saved session at ``path``, write it back: ``Session.load`` must refuse
    it with a ValueError whose message starts with ``field`` (a regular expression: the JSON path of the value)."""
    d = json.loads(path.read_text())
    mutate(d)
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=rf"^{field}"):
        Session.load(path)


def assert_refuses_the_source(write, src, tmp_path) -> None:
    """``write(path)`` (a session's save or export) refuses the session's source file ``src`` and a symbolic link
    to it (``tmp_path / "link.bvh"``, left in place) with "path: ... source file", and leaves ``src`` as it was."""
    before = src.read_bytes()
    link = tmp_path / "link.bvh"
    link.symlink_to(src)
    for path in (src, link):
        with pytest.raises(ValueError, match="^path: .*source file"):
            write(path)
    assert src.read_bytes() == before
