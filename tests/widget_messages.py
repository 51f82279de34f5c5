"""What the kernel sends for a widget, for the tests that count messages."""
from __future__ import annotations


def sends(widget):
    """Messages the kernel sends for ``widget`` (its comm's ``send`` wrapped)."""
    log, orig = [], widget.comm.send

    def send(data=None, metadata=None, buffers=None):
        log.append(data)
        return orig(data=data, metadata=metadata, buffers=buffers)

    widget.comm.send = send
    return log
