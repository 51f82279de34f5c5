"""The editors' controls and their binding to a model: a slider as the editors lay it out, toggles with their
description inline, ``link`` (model trait <-> control value, both ways, a control's range growing to hold the
model's value, a browser's rounded step taken as a step), and ``inert`` (disabled with a tooltip saying why).
Split from :mod:`._editor` (what the three editors share); no math beyond the range and step bookkeeping."""
from __future__ import annotations

import math

import ipywidgets as widgets

_STYLE = {"description_width": "120px"}

def _slider(cls, description, **kw):
    return cls(description=description, continuous_update=True, style=_STYLE, layout=widgets.Layout(width="340px"),
               **kw)


def _inline(toggles):
    """``toggles`` (a ToggleButtons) with its description beside its buttons, as every other described control
    has it (ipywidgets 8 draws a ToggleButtons' description on a line of its own: "warp" and "repetitions" stood
    alone, issue 26): the inline-hbox class of ipywidgets' own stylesheet. Returns ``toggles``."""
    toggles.add_class("jupyter-widget-inline-hbox")
    return toggles


def _grow_range(model, name, control, log=False, to_control=None):
    """Let ``control``'s range grow to show whatever value the model holds (a session's skip = 100 is shown as
    100, never clamped and written back). Registered before the link, so it runs first. ``to_control``: the
    link's model -> control transform (a frame shown in seconds grows the range in seconds)."""
    def grow(change=None):
        v = getattr(model, name)
        if not isinstance(v, (int, float)) or isinstance(v, bool):
            return
        if to_control is not None:
            v = to_control(v)
        x = math.log10(v) if log and v > 0 else v
        if x > control.max:
            control.max = x
        if x < control.min:
            control.min = x
    grow()
    model.observe(grow, names=name)


def _same_value(a, b) -> bool:
    """``a == b``, numbers within float noise (1e-9 relative): a slider's ``min + n * step`` (90.00000000000001)
    that the model rounds (90.0) is not written back to the control. A write-back is a kernel-to-browser update,
    which the browser applies even when the user's next step is already on its way (ipywidgets drops only stale
    echoes): under load, 8 key presses on the cull % slider ended 3 steps further, the others undone."""
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same_value(x, y) for x, y in zip(a, b))
    num = (int, float)
    if isinstance(a, num) and isinstance(b, num) and not isinstance(a, bool) and not isinstance(b, bool):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)
    return a == b


def _stepped(control, old, new):
    """``new`` as the user meant it when it is an arrow-key step of a number box (``FloatText``) from ``old``.

    The browser steps a number box to the next multiple of its ``step`` (counted from 0) above or below the
    shown value. From a value the model rounded to its display precision between two multiples (a pose time
    of 2.0333 s on a 1/120 s grid) that move is less than a step, and the model's rounding puts it back (the
    box never moved on): a value on the step grid less than one step away from ``old`` is taken as one step
    from the multiple nearest ``old``, in the direction pressed. A typed value is not on the grid (to 1e-6 of a
    step) and passes as it is. Sliders need no such rule: they are given values on their page's grid
    (:func:`_on_page_grid`), so a key press moves a whole step, and a value less than a step away is the page's
    snap of what it was given, not a press."""
    step = getattr(control, "step", None)
    if not step or step <= 0 or not isinstance(control, widgets.FloatText):
        return new
    return _step_one(float(step), 0.0, old, new)


def _step_one(step: float, base: float, old, new):
    """One number of :func:`_stepped` on the grid ``base + k * step``."""
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in (old, new)):
        return new
    n = (new - base) / step
    if abs(n - round(n)) > 1e-6 or not 0 < abs(new - old) < step * (1 - 1e-6):
        return new
    return base + (round((old - base) / step) + (1 if new > old else -1)) * step


def _same_grid_point(control, shown) -> bool:
    """``shown`` is a range slider's own value up to display rounding: both numbers within half a step of it. Not
    written back then: while the page's answer is in flight, a quick next key press would start from it and be
    lost (the wand's edit range, browser review D2). Single sliders and number boxes still show the model's
    rounding (a typed 0.41234 reads 0.412)."""
    if not isinstance(control, widgets.FloatRangeSlider) or not control.step or len(shown) != 2:
        return False
    return all(abs(float(a) - float(b)) < 0.5 * control.step for a, b in zip(control.value, shown))


def _page_grid_point(control, v: float) -> float:
    """``v`` as the slider's own grid point ``min + n * step`` (or its ``max``) when it lies within 10 % of a
    step of one (the model rounds to one decimal finer than the step: at most 5 % off), else ``v``. The page's
    slider (noUiSlider) snaps every value it is given to its grid and, when that moves it, sends the snapped
    value back as the user's: the model's 4-decimal rounding of a frame time (3.7417 on a 1/120 s grid) was
    sent back as 3.741667, taken as a move (the WarpEditor's opening warp recorded as an edit) or as an arrow
    step (the segment slider flipped between two frames for ever)."""
    step = getattr(control, "step", None)
    if not step or step <= 0 or isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        return v
    lo, hi = float(control.min), float(control.max)
    n = round((v - lo) / step)
    g = min(max(lo + n * step, lo), hi)
    if abs(v - hi) < abs(v - g):
        g = hi
    return g if abs(v - g) < 0.1 * step else v


def _on_page_grid(control, value):
    """A value (a number, or a range slider's pair) as a float slider's page shows it (:func:`_page_grid_point`);
    other controls' values unchanged."""
    if isinstance(control, widgets.FloatRangeSlider) and isinstance(value, (list, tuple)):
        return tuple(_page_grid_point(control, float(v)) for v in value)
    if isinstance(control, widgets.FloatSlider) and not isinstance(control, widgets.FloatLogSlider):
        return _page_grid_point(control, value)
    return value


class _ControlLink:
    """``model.name`` <-> ``control.value``, both ways, like ``traitlets.link``, except that a value the model
    refuses (``model.set_control``: a TraitError, the reason in ``model.notes[name]``) puts the control back to
    the model's value, a value the model rounds is shown rounded (float noise excepted: :func:`_same_value`), and
    an arrow-key step of a number box moves one step (:func:`_stepped`). ``transform``: ``(to_control, to_model)``."""

    def __init__(self, model, name: str, control, transform=(None, None)):
        self.model, self.name, self.control = model, name, control
        self._to_c = transform[0] or (lambda v: v)
        self._to_m = transform[1] or (lambda v: v)
        self._busy = False
        control.value = self._shown(getattr(model, name))
        model.observe(self._to_control, names=name)
        control.observe(self._to_model, names="value")

    def _shown(self, value):
        """The model's ``value`` as the control shows it: transformed, on the page's slider grid."""
        return _on_page_grid(self.control, self._to_c(value))

    def _to_control(self, change) -> None:
        if not self._busy:
            self._busy = True
            try:
                self.control.value = self._shown(change["new"])
            finally:
                self._busy = False

    def _to_model(self, change) -> None:
        if self._busy or _same_value(change["old"], change["new"]):
            return   # the page's own value up to float noise (its grid arithmetic): not a move
        self._busy = True
        try:
            self.model.set_control(self.name, self._to_m(_stepped(self.control, change["old"], change["new"])))
            shown = self._shown(getattr(self.model, self.name))   # refused: back to the model's value
            if not _same_value(shown, self.control.value) and not _same_grid_point(self.control, shown):
                self.control.value = shown
        finally:
            self._busy = False

    def unlink(self) -> None:
        self.model.unobserve(self._to_control, names=self.name)
        self.control.unobserve(self._to_model, names="value")


def _link(model, name, control, log=False, transform=(None, None)):
    if hasattr(control, "max") and hasattr(control, "min") and not isinstance(control, widgets.IntRangeSlider):
        _grow_range(model, name, control, log=log, to_control=transform[0])
    return _ControlLink(model, name, control, transform)


def _inert(control, inert: bool, why: str, tip: str = "") -> None:
    """Disable ``control`` with a tooltip saying why (or enable it with its normal tooltip)."""
    control.disabled = bool(inert)
    control.tooltip = why if inert else tip
