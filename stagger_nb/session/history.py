"""The op list with undo/redo and observers.

The list is a tuple of typed ops (:mod:`.ops`); each change (``commit``) is one undo step, and a change
that leaves the list equal is no step at all. Changes committed with the same ``gesture`` token, one after
another, are one step (a slider drag or a burst of arrow keys: one undo goes back to before it). Listeners
are called as ``listener(owner)`` after every change, undo and redo included.
"""
from __future__ import annotations

from collections.abc import Callable

__all__ = ["History", "Flag"]


class Flag:
    """A bool that can also be called: ``session.can_undo`` and ``session.can_undo()`` both work (the
    property form is what older widget code reads)."""

    __slots__ = ("_value",)

    def __init__(self, value: bool):
        self._value = bool(value)

    def __bool__(self) -> bool:
        return self._value

    def __call__(self) -> bool:
        return self._value

    def __eq__(self, other) -> bool:
        return self._value == bool(other)

    def __hash__(self) -> int:
        return hash(self._value)

    def __repr__(self) -> str:
        return repr(self._value)


class History:
    """Current op tuple + undo and redo stacks + listeners."""

    def __init__(self, ops: tuple = (), owner=None):
        self.ops: tuple = tuple(ops)
        self._undo: list[tuple] = []
        self._redo: list[tuple] = []
        self._listeners: list[Callable] = []
        self._owner = owner
        self._gesture = None   # the gesture token of the last step (None: that step is closed)

    def commit(self, new_ops, gesture=None) -> bool:
        """Make ``new_ops`` current (one undo step); False (and no step) when nothing changed. With ``gesture``
        (any token) equal to the last commit's, the last step is extended instead of a new one made (and
        dropped when the gesture comes back to where it started); undo and redo close the step."""
        new_ops = tuple(new_ops)
        if new_ops == self.ops:
            return False
        if gesture is not None and gesture == self._gesture and self._undo:
            if new_ops == self._undo[-1]:   # back to before the gesture: no step left
                self._undo.pop()
                self._gesture = None
        else:
            self._undo.append(self.ops)
            self._gesture = gesture
        self._redo.clear()
        self.ops = new_ops
        self._notify()
        return True

    def rebase(self) -> None:
        """Forget the undo and redo stacks: the current op list is where undo stops."""
        if self._undo or self._redo:
            self._undo.clear()
            self._redo.clear()
            self._gesture = None
            self._notify()

    @property
    def can_undo(self) -> bool:
        return bool(self._undo)

    @property
    def can_redo(self) -> bool:
        return bool(self._redo)

    def undo(self) -> bool:
        return self._step(self._undo, self._redo)

    def redo(self) -> bool:
        return self._step(self._redo, self._undo)

    def _step(self, source: list, other: list) -> bool:
        """Undo (``source`` the undo stack) or redo (the redo stack): the op list popped from ``source``
        becomes current, the current one goes onto ``other``; False when ``source`` is empty."""
        if not source:
            return False
        self._gesture = None
        other.append(self.ops)
        self.ops = source.pop()
        self._notify()
        return True

    def observe(self, listener: Callable) -> None:
        self._listeners.append(listener)

    def unobserve(self, listener: Callable) -> None:
        self._listeners = [f for f in self._listeners if f != listener]

    def _notify(self) -> None:
        for f in list(self._listeners):
            f(self._owner)
