"""The joint hierarchy of a character (no motion)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._arrays import readonly

__all__ = ["Skeleton"]


@dataclass(frozen=True, eq=False)
class Skeleton:
    """A frozen joint hierarchy.

    Attributes
    ----------
    names : tuple[str, ...], length J
        Joint names, in file order; parents always come before children.
    parents : ndarray, shape (J,), int
        Index of each joint's parent, ``-1`` for the root (joint 0).
    offsets : ndarray, shape (J, 3)
        Rest translation of each joint relative to its parent, in file units.
    channels : tuple[tuple[str, ...], ...], length J
        Per-joint channel layout as read (e.g. ``("Xposition", ..., "Zrotation", "Xrotation",
        "Yrotation")``), kept so a writer can reproduce the file's layout.
    end_sites : dict[int, ndarray shape (3,)]
        ``End Site`` offsets keyed by the joint that owns them.
    """

    names: tuple
    parents: np.ndarray
    offsets: np.ndarray
    channels: tuple = ()
    end_sites: dict = field(default_factory=dict)

    def __post_init__(self):
        names = tuple(str(n) for n in self.names)
        parents = readonly(self.parents, dtype=np.int64)
        offsets = readonly(self.offsets, dtype=float).reshape(-1, 3)
        J = len(names)
        if parents.shape != (J,) or offsets.shape != (J, 3):
            raise ValueError(f"Skeleton: names ({J}), parents {parents.shape} and offsets {offsets.shape} disagree")
        if len(set(names)) != J:
            seen = set()
            dup = next(n for n in names if n in seen or seen.add(n))
            raise ValueError(f"Skeleton: names must be unique, {dup!r} is used twice")
        if J == 0 or parents[0] != -1:
            raise ValueError("Skeleton: joint 0 must be the root (parent -1)")
        if np.any(parents[1:] < 0) or np.any(parents[1:] >= np.arange(1, J)):
            raise ValueError("Skeleton: every non-root joint's parent must come before it")
        channels = tuple(tuple(c) for c in self.channels) if self.channels else tuple(
            (("Xposition", "Yposition", "Zposition") if j == 0 else ()) + ("Zrotation", "Xrotation", "Yrotation")
            for j in range(J))
        if len(channels) != J:
            raise ValueError(f"Skeleton: channels has {len(channels)} entries for {J} joints")
        end_sites = {int(k): readonly(v).reshape(3) for k, v in dict(self.end_sites).items()}
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "channels", channels)
        object.__setattr__(self, "end_sites", end_sites)

    @property
    def num_joints(self) -> int:
        return len(self.names)

    def index(self, name: str) -> int:
        """Index of joint ``name``; raises ``KeyError`` naming the joint and listing the known ones."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no joint named {name!r}; joints are {', '.join(self.names)}") from None

    def children(self, j: int) -> list[int]:
        """Direct children of joint ``j``."""
        return [int(c) for c in np.flatnonzero(self.parents == j)]

    def depth(self) -> np.ndarray:
        """Depth of each joint from the root, shape (J,), root = 0."""
        d = np.zeros(self.num_joints, dtype=int)
        for j in range(1, self.num_joints):
            d[j] = d[self.parents[j]] + 1
        return d

    def tree_distance(self, root: int | str) -> np.ndarray:
        """Number of bones between ``root`` and every joint along the hierarchy, shape (J,)."""
        r = self.index(root) if isinstance(root, str) else int(root)
        J = self.num_joints
        adj = [[] for _ in range(J)]
        for j in range(1, J):
            adj[j].append(int(self.parents[j]))
            adj[int(self.parents[j])].append(j)
        dist = np.full(J, -1, dtype=int)
        dist[r] = 0
        queue = [r]
        for u in queue:
            for v in adj[u]:
                if dist[v] < 0:
                    dist[v] = dist[u] + 1
                    queue.append(v)
        return dist

    def is_leaf(self) -> np.ndarray:
        """Boolean (J,): joints with no child joint."""
        leaf = np.ones(self.num_joints, dtype=bool)
        leaf[self.parents[1:]] = False
        return leaf

    def has_position_channels(self, j: int) -> bool:
        return any(c.lower().endswith("position") for c in self.channels[j])

    def __eq__(self, other):
        return (isinstance(other, Skeleton) and self.names == other.names
                and np.array_equal(self.parents, other.parents) and np.array_equal(self.offsets, other.offsets)
                and self.channels == other.channels and self.end_sites.keys() == other.end_sites.keys()
                and all(np.array_equal(self.end_sites[k], other.end_sites[k]) for k in self.end_sites))

    __hash__ = object.__hash__
