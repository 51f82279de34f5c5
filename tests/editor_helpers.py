"""Helpers shared by the editor tests (imported as ``editor_helpers``; no test module imports another)."""
from __future__ import annotations

import threading
import time


def from_browser(widget, **state) -> None:
    """Apply ``state`` as an update message from the browser (ipywidgets' comm message handler)."""
    widget._handle_msg({"content": {"data": {"method": "update", "state": state, "buffer_paths": []}}, "buffers": []})


def warm_threads() -> list:
    """The live warm-up threads of every session in this process."""
    return [t for t in threading.enumerate() if t.name == "stagger_nb-warm" and t.is_alive()]


def wait_until(condition, seconds: float = 60.0, step: float = 0.2) -> bool:
    """Poll ``condition()`` until it is true or ``seconds`` have passed; returns its last value (for work that
    ends on another thread, e.g. a warm-up finishing the item it runs; never used to assert a duration)."""
    end = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > end:
            return bool(condition())
        time.sleep(step)
    return True


def rss_mb() -> float:
    """Resident memory of this process (MB), from /proc (Linux)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def page_snap(control, value: float) -> float:
    """``value`` snapped as the page's slider (noUiSlider) snaps it: in percent of the track, to the nearest step
    (the track's end is a stop too), and back to a value. Its own arithmetic: the grid points it gives differ
    from ``min + n * step`` computed in Python by float noise, as the page's do."""
    lo, hi, step = float(control.min), float(control.max), float(control.step)
    span = hi - lo
    pct, step_pct = (value - lo) / span * 100.0, step / span * 100.0
    snapped = min(round(pct / step_pct) * step_pct, 100.0)
    if 100.0 - pct < abs(pct - snapped):
        snapped = 100.0
    if snapped >= 100.0:   # the track's ends are its min and max themselves (noUiSlider's fromStepping)
        return hi
    return lo + snapped * span / 100.0 if snapped > 0 else lo


def page_echoes(control, rounds: int = 20) -> int:
    """Act as the page does with a continuously updating float slider (ipywidgets 8): each value the kernel gives
    it is snapped to its grid (:func:`page_snap`) and, when that moved it, sent back as the user's value; the page
    sends nothing more once the kernel keeps what it sent. Returns the number of values sent back before the page
    and the kernel agree (``rounds`` when they never do)."""
    for i in range(rounds):
        v = control.value
        if isinstance(v, (list, tuple)):
            snapped = [page_snap(control, float(x)) for x in v]
            if snapped == [float(x) for x in v]:
                return i
        else:
            snapped = page_snap(control, float(v))
            if snapped == float(v):
                return i
        from_browser(control, value=snapped)
        if list(control.value) == snapped if isinstance(v, (list, tuple)) else control.value == snapped:
            return i + 1   # the kernel kept the page's value: nothing more is sent either way
    return rounds
