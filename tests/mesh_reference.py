"""Naive twin of the skeleton mesh builder (``stagger_nb/widgets/_skeleton_mesh.js``, the only builder the package
runs): the same affine maps written with numpy, for the tests that check the browser's mesh."""
from __future__ import annotations

import numpy as np

from stagger_nb import scene3d


def _bone_frames(a: np.ndarray, b: np.ndarray):
    """Right-handed orthonormal frames of bones from ``a (B, 3)`` to ``b (B, 3)``: axes x, y (along the bone),
    z, each (B, 3), and lengths (B,). A zero-length bone gets y = +y. The helper axis for x is +x, or +z when
    the bone is nearly along x (same rule in ``_skeleton_mesh.js``)."""
    d = b - a
    length = np.linalg.norm(d, axis=1)
    y = np.where(length[:, None] > 1e-12, d / np.maximum(length, 1e-12)[:, None], [0.0, 1.0, 0.0])
    helper = np.where(np.abs(y[:, :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    x = np.cross(y, helper)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return x, y, np.cross(x, y), length


def skeleton_mesh(points: np.ndarray, segs: np.ndarray, num_joints: int, joint_radius: float,
                  bone_radius: float, template: scene3d.MeshTemplate, selected=(), selected_scale: float = 1.6):
    """The merged skeleton mesh of one frame: ``positions (V, 3)``, ``normals (V, 3)`` float32.

    ``points (P, 3)``: world points of the frame (``scene3d.skeleton_points``); vertices are the joint spheres
    (joint j: rows ``j Vs .. (j+1) Vs``, radius ``joint_radius``, × ``selected_scale`` for ``selected`` joints)
    then the bone tubes (bone i from ``segs[i, 0]`` to ``segs[i, 1]``, radius ``bone_radius``), each the template
    mapped by the bone's frame (:func:`_bone_frames`)."""
    P = np.asarray(points, dtype=float)
    J = int(num_joints)
    r = np.full(J, float(joint_radius))
    r[list(selected)] *= selected_scale
    s = template.sphere.astype(float)
    sp = (P[:J, None, :] + r[:, None, None] * s[None, :, :3]).reshape(-1, 3)
    sn = np.broadcast_to(s[None, :, 3:], (J,) + s[:, 3:].shape).reshape(-1, 3)
    a, b = P[segs[:, 0]], P[segs[:, 1]]
    x, y, z, length = _bone_frames(a, b)
    t = template.tube.astype(float)
    scale = np.stack([np.full_like(length, bone_radius), length, np.full_like(length, bone_radius)], 1)
    axes = np.stack([x, y, z], 1)                                  # (B, 3 axes, 3)
    # vertex v of bone b: a_b + sum_k t_vk scale_bk axes_bkc, as (V, 3) @ (B, 3, 3) matrix products (a 3-operand
    # einsum took ~15x longer here)
    tp = a[:, None] + t[None, :, :3] @ (scale[:, :, None] * axes)
    tn = t[None, :, 3:] @ axes
    return (np.concatenate([sp, tp.reshape(-1, 3)]).astype(np.float32),
            np.concatenate([sn, tn.reshape(-1, 3)]).astype(np.float32))


_SCRIPT = __import__("pathlib").Path(__file__).with_name("node") / "conductor_frame.mjs"
_REFS = ("player", "scene", "rig", "skeleton", "ghost", "trails", "layout", "tabbable", "tooltip")
_BUFFERS = ("points", "template", "states", "rig_path", "ghost_points", "preview")


def browser_mesh(view, frame, tmp_path):
    """What the view's browser clock (``_conductor.js`` with ``_skeleton_mesh.js``, run in node against stand-in
    models by ``tests/node/conductor_frame.mjs``) writes into the skeleton mesh for ``frame``: ``(positions,
    normals, colours)`` each (V, 3) float32, and ``{"shown_frame", "rig"}``. Skips the test when node is missing."""
    import base64
    import json
    import shutil
    import subprocess

    import pytest
    if shutil.which("node") is None:
        pytest.skip("node is not installed: the browser's mesh builder cannot run here")
    c = view.conductor
    traits = {k: getattr(c, k) for k in c.keys if not k.startswith("_") and k not in _REFS}
    for k in _BUFFERS:
        traits[k] = base64.b64encode(traits[k]).decode()
    g = view.skeleton_mesh.geometry.attributes
    V = len(np.asarray(g["position"].array))
    state = tmp_path / "state.json"
    state.write_text(json.dumps({"traits": traits, "buffers": list(_BUFFERS), "vertices": V, "frame": int(frame),
                                 "normal": np.asarray(g["normal"].array, np.float32).ravel().tolist(),
                                 "color": np.asarray(g["color"].array, np.float32).ravel().tolist()}))
    out = tmp_path / "out.f32"
    r = subprocess.run(["node", str(_SCRIPT), str(state), str(out)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]
    info = json.loads(r.stdout.strip().splitlines()[-1])
    pos, nrm, col = np.fromfile(out, np.float32).reshape(3, V, 3)
    return pos, nrm, col, info
