"""An editor's life on the kernel: listeners held weakly (a session does not keep a closed editor alive),
callbacks run on the kernel's IOLoop (now from the warm-up worker, or once edits rest), what closing an editor
stops (its warm-ups, the worker of a session it made) and the widgets it closes. No widgets are made here."""
from __future__ import annotations

import weakref

import ipywidgets as widgets


def _weakly(method):
    """``method`` (bound) called through a weak reference: a listener a session keeps does not keep the editor
    alive (a dead editor's listener does nothing)."""
    ref = weakref.WeakMethod(method)

    def call(*args):
        m = ref()
        if m is not None:
            m(*args)
    return call


def _widgets_under(root: widgets.Widget, keep=()) -> list:
    """Every widget reachable from ``root`` through its traits and attributes (a 3D view's pythreejs scene,
    camera, picker, meshes, geometries and links; in lists, tuples and dicts too), ``root`` included, those in
    ``keep`` left out:
    what closing an editor closes, so none stays registered with ipywidgets (which would keep the editor
    alive through their observers)."""
    out, stack, seen = [], [root], {id(k) for k in keep}
    while stack:
        w = stack.pop()
        if id(w) in seen:
            continue
        seen.add(id(w))
        out.append(w)
        values = [w._trait_values.get(name) for name in w.trait_names()] + list(vars(w).values())
        for v in values:   # traits, and attributes (the links a view keeps for itself)
            for x in (v if isinstance(v, (list, tuple)) else v.values() if isinstance(v, dict) else (v,)):
                if isinstance(x, widgets.Widget):
                    stack.append(x)
                elif isinstance(x, tuple) and x and isinstance(x[0], widgets.Widget):   # a link's (widget, name)
                    stack.append(x[0])
    return out


def _stop_work(futures: list, session) -> None:
    """What closing (or collecting) an editor stops: its warm-ups, and the session's worker when the editor made
    the session itself."""
    for f in futures:
        f.cancel()
    if session is not None:
        session.close()


def _on_kernel_thread(fn, *args) -> None:
    """Run ``fn(*args)`` on the kernel's own thread (the IOLoop, where widget messages and user edits run) when
    called from the session's warm-up worker; directly outside a kernel (scripts, tests)."""
    try:
        from IPython import get_ipython
        loop = getattr(getattr(get_ipython(), "kernel", None), "io_loop", None)
    except ImportError:
        loop = None
    if loop is None:
        fn(*args)
    else:
        loop.add_callback(fn, *args)


def _on_kernel_loop_later(delay: float, fn):
    """``fn()`` on the kernel's IOLoop ``delay`` seconds from now (a handle with ``cancel()``); at once (and
    None) outside a kernel (scripts, tests)."""
    try:
        from IPython import get_ipython
        loop = getattr(getattr(get_ipython(), "kernel", None), "io_loop", None)
    except ImportError:
        loop = None
    if loop is None:
        fn()
        return None
    h = loop.call_later(delay, fn)

    class _Handle:
        def cancel(self):
            loop.remove_timeout(h)
    return _Handle()

