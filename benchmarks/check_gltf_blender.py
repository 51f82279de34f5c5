"""Optional check with Blender (the PyPI ``bpy`` module, ~370 MB, not a dependency): import the ``.glb`` export of
every real clip and of a 100-joint rig with position channels on every joint, and compare the armature's
animated bone heads with the package's FK over all frames.

    .venv/bin/python benchmarks/check_gltf_blender.py --bpy-python /tmp/bpyvenv/bin/python

(``python3.11 -m venv /tmp/bpyvenv && /tmp/bpyvenv/bin/pip install bpy``.) This process writes the exports and
the FK positions (metres, glTF's Y-up) to a temp folder; the bpy interpreter imports each file with Blender's
glTF importer (defaults), checks one armature with a bone per joint, samples the scene at every key time
(fractional frames) and prints the largest distance as a fraction of the rest height.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def blender_side(files: list[str]) -> int:
    import bpy  # only in the bpy interpreter
    worst = 0.0
    for glb in files:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        bpy.ops.import_scene.gltf(filepath=glb)
        arms = [o for o in bpy.data.objects if o.type == "ARMATURE"]
        ref = np.load(glb[:-4] + ".npz")
        want, names, times = ref["pos"], [str(n) for n in ref["names"]], ref["times"]
        arm, scene = arms[0], bpy.context.scene
        fps = scene.render.fps / scene.render.fps_base
        got = np.zeros_like(want)
        for f, t in enumerate(times):
            whole = int(np.floor(t * fps))
            scene.frame_set(whole, subframe=float(t * fps - whole))
            M = np.array(arm.matrix_world)
            for j, n in enumerate(names):
                h = M @ np.append(np.array(arm.pose.bones[n].head), 1.0)
                got[f, j] = [h[0], h[2], -h[1]]  # Blender Z-up -> glTF Y-up
        err = np.abs(got - want).max() / float(ref["height"])
        worst = max(worst, err)
        print(f"{os.path.basename(glb)}: armatures {len(arms)}, bones {len(arm.data.bones)} (joints {len(names)}), "
              f"frames {len(times)}: max |Blender - FK| = {err:.2e} of height")
    return 0 if worst <= 1e-5 else 1


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bpy-python", required=True)
    args = ap.parse_args()
    repo = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(repo))
    sys.path.insert(0, str(repo / "tests"))
    from test_io_gltf import random_rig, real_clips

    import stagger_nb as sn
    from stagger_nb.core.kinematics import skeleton_height
    from stagger_nb.io.gltf import metres_per_unit
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        motions = [(os.path.basename(c)[:-4], sn.read_bvh(c)) for c in real_clips()]
        sn.write_bvh(random_rig(), os.path.join(tmp, "rig.bvh"))
        motions.append(("rig100_position_channels", sn.read_bvh(os.path.join(tmp, "rig.bvh"))))
        for name, m in motions:
            base = os.path.join(tmp, name)
            sn.write_gltf(m, base + ".glb")
            _, s = metres_per_unit(m)
            np.savez(base + ".npz", pos=sn.forward_kinematics(m)[0] * s, names=np.array(m.skeleton.names),
                     times=(np.arange(m.num_frames) * m.frame_time).astype(np.float32).astype(float),
                     height=skeleton_height(m) * s)
            files.append(base + ".glb")
        return subprocess.run([args.bpy_python, __file__, "--blender-side", *files], timeout=1800).returncode


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--blender-side":
        sys.exit(blender_side(sys.argv[2:]))
    sys.exit(main())
