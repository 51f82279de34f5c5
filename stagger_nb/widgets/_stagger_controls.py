"""The StaggerEditor's controls and tool groups: one control per :class:`~stagger_nb.session.models.StaggerModel`
trait (steps from the model), the main sliders, and the tabs they are grouped in (cull, timing, pose, IK,
contacts) with their hints. Built, not bound: :mod:`.stagger_editor` links them to the model."""
from __future__ import annotations

import html

import ipywidgets as widgets

from ..core.motion import Motion
from ..session.models import StaggerModel
from ._controls import _STYLE, _slider


def _controls(m: Motion, names: list, model: StaggerModel) -> dict:
    """The StaggerEditor's controls by model trait name (each is linked to that trait; steps from the model)."""
    wide = {"style": _STYLE}
    st = model.step
    c = {}
    c["cull_by"] = widgets.ToggleButtons(options=[("by %", "percent"), ("by count", "count"), ("picked", "keep")],
                                         description="cull poses", style={**_STYLE, "button_width": "84px"},
                                         tooltips=["keep a percentage of the poses, by priority",
                                                   "keep a number of poses, by priority",
                                                   "keep the poses you pick (click the probability plot)"])
    c["percent"] = _slider(widgets.FloatSlider, "keep poses %", min=5.0, max=100.0, step=st("percent"),
                           readout_format=".0f")
    c["count"] = widgets.BoundedIntText(min=0, max=10**6, description="keep (0 = all)", **wide,
                                        layout=widgets.Layout(width="230px"))
    c["keep"] = widgets.SelectMultiple(options=[], rows=3, description="keep poses", **wide,
                                       layout=widgets.Layout(width="260px"))
    c["root"] = widgets.Dropdown(options=names, description="succession root", **wide)
    c["joints"] = widgets.SelectMultiple(options=names, rows=4, description="delayed joints", **wide,
                                         layout=widgets.Layout(width="280px"))
    c["s"] = _slider(widgets.FloatSlider, "s (s/bone)", min=-0.1, max=0.1, step=st("s"), readout_format=".3f")
    c["l"] = _slider(widgets.FloatSlider, "exponent l", min=0.25, max=4.0, step=st("l"))
    c["tau"] = _slider(widgets.FloatSlider, "random τ (s)", min=0.0, max=0.15, step=st("tau"), readout_format=".3f")
    c["seed"] = widgets.BoundedIntText(min=0, max=2**31 - 1, description="seed", **wide,
                                       layout=widgets.Layout(width="200px"))
    c["tau_joints"] = widgets.SelectMultiple(options=names, rows=4, description="τ joints", **wide,
                                             layout=widgets.Layout(width="280px"))
    c["w_r"] = _slider(widgets.FloatSlider, "exaggerate w_r", min=-1.0, max=2.0, step=st("w_r"))
    c["w_r_reference"] = widgets.Dropdown(options=[("previous", "previous"), ("next", "next"), ("mean", "mean")],
                                          description="against", **wide)
    c["pose"] = _slider(widgets.IntSlider, "pose k", min=0, max=1)
    c["joint"] = widgets.Dropdown(options=names, description="joint", **wide)
    # each button as wide as its label ("unstaggered" was cut to "unstagger…" at 100 px)
    c["edit_mode"] = widgets.ToggleButtons(options=["staggered", "unstaggered"], description="edit mode",
                                           style={**_STYLE, "button_width": "auto"},
                                           tooltips=["the edit follows each joint's own timing (Fig. 6a)",
                                                     "the edit lands at the pose time for every joint (Fig. 6b)"])
    for a in "xyz":
        c["r" + a] = _slider(widgets.FloatSlider, f"nudge {a} (°)", min=-90.0, max=90.0, step=st("r" + a))
    # a plain FloatText: a typed value outside the neighbours' times is refused by the model with a sentence
    # saying where it may lie (a bounded text box would clamp it silently)
    c["pose_time"] = widgets.FloatText(step=st("pose_time"), description="pose time (s)", **wide,
                                       layout=widgets.Layout(width="230px"))
    c["keep_contacts"] = widgets.Checkbox(description="keep foot contacts", indent=False)
    c["ik_joint"] = widgets.Dropdown(options=[("(none)", "")] + [(n, n) for n in model.ik_effectors],
                                     description="IK effector", **wide)
    for a in "xyz":
        c["ik_" + a] = _slider(widgets.FloatSlider, f"target {a}", min=-1.0, max=1.0, step=st("ik_" + a),
                               readout_format=".3f")
    c["propagate"] = widgets.Checkbox(description="propagate pose edits to similar poses", indent=False,
                                      tooltip="the magic wand (Dean et al. 2018 §3.3): each nudge and IK target "
                                              "changes every similar pose, weighted by the Green's falloff")
    c["region"] = widgets.Checkbox(description="timing edits in a region", indent=False,
                                   tooltip="s and τ scaled by the magic-wand falloff around the region frame "
                                           "(turning it on centres it on the selected pose)")
    c["region_frame"] = widgets.BoundedIntText(min=0, max=max(m.num_frames - 1, 0), description="region frame",
                                               **wide, layout=widgets.Layout(width="230px"))
    c["sigma"] = widgets.BoundedFloatText(min=0.0, max=1e6, step=0.05, description="wand σ (0 = auto)", **wide,
                                          layout=widgets.Layout(width="230px"))
    for k in ("cull_by", "percent", "count", "s", "l", "tau", "w_r", "keep_contacts", "propagate", "region",
              "region_frame", "sigma"):
        c[k].add_class(f"sn-{k.replace('_', '-')}")
    c["percent"].add_class("sn-cull")   # its former name (browser checks)
    for k in ("pose", "ik_joint", "ik_x", "ik_y", "ik_z"):
        c[k].add_class(f"sn-{k.replace('_', '-')}")
    return c


#: what the picked-poses list does (its tooltip, and the hint beside it)
KEEP_TIP = ("with 'picked', the poses kept: select them here (ctrl- or shift-click for several) or click them on "
            "the pose-probability plot")
#: what the IK tab says while no effector is chosen (its target sliders are disabled until one is)
IK_TIP = "choose an IK effector (a hand or foot) first: the target sliders then move it at pose k"


def _hint(text: str, width: str | None = None) -> widgets.HTML:
    """A short grey sentence saying what the controls beside it do (its own line height: a widget's text lines
    are 28 px apart)."""
    return widgets.HTML(f'<div style="font-size:11px;line-height:14px;color:#4a5568">{html.escape(text)}</div>',
                        layout=widgets.Layout(width=width, margin="0 0 0 8px") if width else
                        widgets.Layout(margin="0 0 0 8px"))


def _tools(c: dict, insert: widgets.Button, delete: widgets.Button, note=None, ik_hint=None) -> tuple[list, dict]:
    """(the main sliders, always shown: cull %, s, τ, w_r; the tools, one tab each: their other settings). The
    propagation of pose edits (issue 24) sits with the pose edits it spreads, the region of the timing edits with
    the timing; the wand's σ serves both and shows in both tabs (one control, two views). The picked-poses list
    has its hint beside it (the tab no taller); ``ik_hint`` goes under the IK effector."""
    quick = [c["percent"], c["s"], c["tau"], c["w_r"]]
    keep_hint = _hint("pick poses: select them here (ctrl-click for several) or click them on the probability plot",
                      width="136px")
    keep_hint.add_class("sn-keep-hint")
    tools = {"cull": [widgets.HBox([c["cull_by"]]), widgets.HBox([c["count"]]),
                      widgets.HBox([c["keep"], keep_hint], layout=widgets.Layout(align_items="center"))],
             "timing": [widgets.HBox([c["root"], c["l"]]), widgets.HBox([c["joints"]]),
                        widgets.HBox([c["seed"], c["tau_joints"]]), widgets.HBox([c["region"], c["region_frame"]]),
                        widgets.HBox([c["sigma"]])],
             "pose": [widgets.HBox([c["pose"], c["joint"]]), widgets.HBox([c["w_r_reference"], c["edit_mode"]]),
                      widgets.HBox([c["rx"], c["ry"], c["rz"]]), widgets.HBox([c["pose_time"], insert, delete]),
                      *([widgets.HBox([note])] if note is not None else []),
                      widgets.HBox([c["propagate"], c["sigma"]])],
             "IK": [widgets.HBox([c["ik_joint"]]), *([widgets.HBox([ik_hint])] if ik_hint is not None else []),
                    widgets.HBox([c["ik_x"], c["ik_y"], c["ik_z"]])],
             "contacts": [widgets.HBox([c["keep_contacts"]]),
                          widgets.HTML('<span style="font-size:12px;color:#4a5568">the source\'s foot contacts, '
                                       "carried through the timing edits, are held by IK</span>")]}
    return quick, tools

