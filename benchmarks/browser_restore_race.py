"""JupyterLab's widget restore race, shown with a plain ipywidgets IntSlider (no stagger_nb code at all).

Why: tests/browser_harness.py ``save_and_reload`` sees "Error displaying widget: model not found" on about one
first reload in ten under load. This script shows that the error is JupyterLab's (jupyterlab_widgets 3.0.17),
not the editors': a notebook holding one plain ``IntSlider`` is saved and the tab reloaded with the kernel alive,
while the kernel answers the page's ``request_states`` (the widget restore) ``D`` seconds late (a kernel slowed by
load, simulated with ``time.sleep`` in ipywidgets' control-comm handler). For each D it prints whether the slider
came back or the error showed.

The cause, read in jupyterlab_widgets' renderer (``WidgetRenderer.renderModel``) and the base manager
(``get_model``): each output asks for its model with a 2 s poll in 100 ms steps and no last look after the
deadline; if the restore completed between the poll's last look and its deadline (or, with many models, during a
long main-thread task that straddles the deadline), ``restoredStatus`` is already true when the poll gives up,
and the renderer shows the error for good instead of waiting for the ``restored`` signal. A restore that ends well
before or after the deadline is fine. So: a user's first F5 can hit it with any widget; a second F5 restores.

Run: ``python benchmarks/browser_restore_race.py [DELAYS...]`` (needs /usr/bin/chromium and playwright; ~2 min).
Prints one line per reload: delay, outcome, time from navigation to outcome, load average.
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import browser_harness as bh

CELLS = [
    """import time, ipywidgets as W
DELAY = 0.0   # seconds the kernel waits before answering the page's request_states (set by this script)
_answer = W.Widget._handle_control_comm_msg
def _late(msg):
    if msg["content"]["data"].get("method") == "request_states":
        time.sleep(DELAY)
    return _answer(msg)
W.Widget._handle_control_comm_msg = staticmethod(_late)
s = W.IntSlider(5, description="plain")
s""",
    f"print({bh.DONE!r})",
]

OUTCOME = f"""() => document.body.textContent.includes({bh.MODEL_NOT_FOUND!r}) ? 'model not found' :
                 (document.querySelector('.jp-OutputArea-output .widget-slider') ? 'slider shown' : null)"""


def main(delays: list[float]) -> None:
    reason = bh.skip_reason()
    if reason:
        print("SKIP:", reason)
        return
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        bh.write_notebook(folder / "plain.ipynb", CELLS)
        with bh.jupyter_lab(folder) as url, bh.chromium_page() as (page, log):
            bh.open_notebook(page, url, "plain.ipynb")
            bh.run_all_cells(page)
            page.wait_for_selector(".jp-OutputArea-output .widget-slider")
            page.keyboard.press("Control+s")
            page.wait_for_function("() => !document.querySelector('.jp-mod-dirty')", timeout=30000)
            target = page.url.split("?")[0]
            kernel = bh.Kernel(bh.runtime_dir(folder))
            tally: dict[str, list[float]] = {}
            print(f"{'delay s':>8} {'outcome':>16} {'seconds':>8}  load")
            for d in delays:
                kernel.run(f"DELAY = {d}")
                t0 = time.monotonic()
                page.goto(target, wait_until="domcontentloaded", timeout=90000)
                handle = page.wait_for_function(OUTCOME, timeout=90000, polling=50)
                outcome = handle.json_value()
                dt = time.monotonic() - t0
                tally.setdefault(outcome, []).append(d)
                print(f"{d:8.2f} {outcome:>16} {dt:8.2f}  {os.getloadavg()[0]:.1f}", flush=True)
                bh.wait_kernel_idle(page)
            kernel.close()
    print("delays that showed the error:", tally.get("model not found", []))


if __name__ == "__main__":
    main([float(x) for x in sys.argv[1:]] or [0.0, 0.5, 1.0, 1.5] + [round(1.6 + 0.1 * k, 2) for k in range(12)])
