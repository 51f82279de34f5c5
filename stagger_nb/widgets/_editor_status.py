"""The editor's top bar and message line: undo/redo enabled from the session, the progress bar while work runs,
the model's quality line (each part whole, two lines at most), and the message line (a replay error, the model's
message, refused controls' notes, the runners' notes, the timing warnings). A mixin of :class:`._editor._Editor`."""
from __future__ import annotations

import html

from ._sizes import _LINES


class _StatusLine:
    """The top bar's state (undo/redo, progress, quality) and the message line of an editor."""

    #: the quality line's box: two lines of 12 px text in the height of the top bar's buttons (28 px)
    _QUALITY_LINES, _QUALITY_LINE_PX = 2, 14

    def _show_quality(self, change=None) -> None:
        """The quality line: the model's summary, each part green or red (``ok`` False: out of bounds). Parts
        wrap between words, never inside one: each part is a box of its own (``sn-quality-part``) that moves to
        the next line whole, two lines at most (a part that would start a third is left to the tooltip, which
        holds the whole summary)."""
        q = getattr(self.model, "quality", "") or ""
        if not isinstance(q, dict):
            q = {"text": str(q), "ok": True}
        items = q.get("items") or ([{"text": q["text"], "ok": q.get("ok", True)}] if q.get("text") else [])
        parts = [f'<span class="sn-quality-part" style="display:inline-block;max-width:100%;margin-right:6px">'
                 f'{"&middot; " if k else ""}<span style="color:{"#2f855a" if i.get("ok", True) else "#c53030"}">'
                 f'{html.escape(i["text"])}</span></span>' for k, i in enumerate(items)]
        tip = " · ".join(i["text"] for i in items)
        self.quality.tooltip = tip or None
        n, px = self._QUALITY_LINES, self._QUALITY_LINE_PX
        self.quality.value = (f'<div title="{html.escape(tip)}" style="font-size:12px;line-height:{px}px;'
                              f'max-height:{n * px}px;overflow:hidden;white-space:normal;overflow-wrap:normal;'
                              f'word-break:normal">{"".join(parts)}</div>' if parts else "")

    def _show_progress(self, shown: bool) -> None:
        """The progress bar in the top bar while work runs, out of the layout otherwise."""
        self.progress.layout.display = None if shown else "none"

    def _update_buttons(self):
        self.undo_button.disabled = not self.session.can_undo
        self.redo_button.disabled = not self.session.can_redo

    def _on_busy(self, kind: str, started: bool) -> None:
        labels = {"extract": "extracting poses", "graph": "pose graph", "basis": "eigenvectors",
                  "warp": "kNN tables", "cull": "culling poses"}
        if started:
            self.progress.description = labels.get(kind, kind)
            self.progress.value = 0
            self._show_progress(True)
        else:
            self.progress.value = self.progress.max
            self._show_progress(False)

    def _on_progress(self, done, total, label) -> None:
        if total > 1:
            self.progress.max = total
            self.progress.value = done

    def _notes(self) -> list:
        """Plain notes of the last replay (``Session.messages`` when the session has it)."""
        get = getattr(self.session, "messages", None)
        return list(get()) if callable(get) else []

    def _warnings_html(self) -> str:
        return ""

    def _show_message(self, change=None) -> None:
        """The message line: a replay error, the model's message, each refused control's note (why its last
        value was refused), the runners' notes, the model's hint (a suggestion, in blue) and the timing warnings."""
        parts = []
        beside = {self.model.notes.get(k, "") for k in self._NOTES_BESIDE}   # said once, beside their control
        shown = set(beside)
        for text in (self.error, self.model.message, *self.model.notes.values()):
            if text and text not in shown:
                shown.add(text)
                parts.append(f'<div class="sn-refused" style="color:#c53030;{_LINES}">&#9888; '
                             f'{html.escape(text)}</div>')
        for text in self._notes():
            parts.append(f'<div style="color:#b7791f;{_LINES}">{html.escape(text)}</div>')
        if self.model.hint:
            parts.append(f'<div class="sn-hint" style="color:#2b6cb0;{_LINES}">tip: '
                         f'{html.escape(self.model.hint)}</div>')
        w = self._warnings_html()
        if w:
            parts.append(w)
        self.message.value = "".join(parts)
