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
