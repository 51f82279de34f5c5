"""The browser half of SkeletonView, ``_conductor.js``, run in node against stand-in models
(``tests/node/conductor_frame.mjs``): for a shown frame it must write the same mesh as the kernel's
:func:`stagger_nb.scene3d.skeleton_mesh` (vertex positions, the tubes' normals, the joints' state colours) and put
the rig where the follow camera has it. Skipped, with the reason, only when node is missing."""
from __future__ import annotations

import base64
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import stagger_nb as sn
from stagger_nb.widgets import SkeletonView

SCRIPT = Path(__file__).with_name("node") / "conductor_frame.mjs"
_REFS = ("player", "scene", "rig", "skeleton", "ghost", "trails", "layout", "tabbable", "tooltip")
_BUFFERS = ("points", "template", "states", "rig_path", "ghost_points")


def _run_conductor(view: SkeletonView, frame, tmp_path: Path):
    if shutil.which("node") is None:
        pytest.skip("node is not installed")
    c = view.conductor
    traits = {k: getattr(c, k) for k in c.keys if not k.startswith("_") and k not in _REFS}
    for k in _BUFFERS:
        traits[k] = base64.b64encode(traits[k]).decode()
    V = len(np.asarray(view.skeleton_mesh.geometry.attributes["position"].array))
    state = tmp_path / "state.json"
    state.write_text(json.dumps({"traits": traits, "buffers": list(_BUFFERS), "vertices": V, "frame": frame}))
    out = tmp_path / "out.f32"
    r = subprocess.run(["node", str(SCRIPT), str(state), str(out)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]
    info = json.loads(r.stdout.strip().splitlines()[-1])
    return np.fromfile(out, np.float32).reshape(3, V, 3), info


@pytest.mark.parametrize("clip, frame", [("run", 77), ("cmu_01_01", 1200)])
def test_the_browser_builds_the_kernels_mesh(clip, frame, tmp_path):
    m = sn.data.load(clip)
    v = SkeletonView(m)
    v.set_pose_frames([frame])                     # every joint flashes orange at this frame ...
    v.highlight_joints(["Head"])                   # ... but the selected head is red and larger
    v.frame = frame
    v._push_mesh()                                 # the kernel's still picture of this frame
    (pos, nrm, col), info = _run_conductor(v, frame, tmp_path)
    g = v.skeleton_mesh.geometry.attributes
    want_pos, want_nrm, want_col = (np.asarray(g[k].array) for k in ("position", "normal", "color"))
    scale = np.abs(want_pos).max()
    np.testing.assert_allclose(pos, want_pos, atol=1e-5 * scale)   # float32 rounding of the same affine maps
    spheres = m.num_joints * len(sn.scene3d.mesh_template().sphere)
    # the clock rewrites the tubes' normals (they turn with the bones) and the joints' colours (they change
    # with the frame's state); the spheres' normals and the bones' colours never change, so it leaves them
    np.testing.assert_allclose(nrm[spheres:], want_nrm[spheres:], atol=1e-5)
    np.testing.assert_allclose(col[:spheres], want_col[:spheres], atol=1e-7)
    head = m.skeleton.index("Head") * len(sn.scene3d.mesh_template().sphere)
    assert col[head].tolist() != col[0].tolist()   # red head, orange rest
    np.testing.assert_allclose(info["rig"], -v.camera_framing.rig[frame], atol=1e-3)
    assert info["shown_frame"] == frame
