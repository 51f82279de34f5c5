"""glTF 2.0 export: a :class:`~stagger_nb.core.Motion` as a skinned skeleton with one animation.

What the file holds (Khronos glTF 2.0 specification, §3.5 nodes, §3.7 skins, §3.11 animations):

- one node per joint, named after the joint, in the skeleton's hierarchy; each node's rest transform is the
  joint's BVH offset (identity rotation), so the bind pose is the skeleton's rest pose;
- one ``skins`` entry listing every joint (in ``skeleton.names`` order) with its inverse bind matrix, and a
  small skinned mesh (one triangle per joint, weight 1 to that joint) on a root node, so importers such as
  Blender build an *armature* from the skin rather than empty objects;
- one animation: a ``rotation`` channel per joint (the motion's local quaternions, already (x, y, z, w) as
  glTF wants, made hemisphere-continuous) and a ``translation`` channel for the root and for every joint
  whose translation is animated (BVH position channels); ``LINEAR`` sampling at the clip's frame times
  ``t_i = i * frame_time`` seconds.

Units: glTF lengths are metres. BVH and ASF/AMC files carry no unit, so the rule is by the rest pose's
height ``h`` (:func:`~stagger_nb.core.kinematics.skeleton_height`, file units), assuming a human-sized rig
(about 1-2.2 m):

=================  ==========================  ===================
``h`` (file units)  assumed unit               metres per unit
=================  ==========================  ===================
``h <= 3``          metres                      1
``3 < h <= 38``     CMU ASF units (in * 0.45)   0.0254 / 0.45
``38 < h <= 100``   inches                      0.0254
``100 < h <= 400``  centimetres                 0.01
``h > 400``         millimetres                 0.001
=================  ==========================  ===================

(The CMU-derived BVH conversions, e.g. cgspeed's, keep the ASF's ``:units length 0.45``, hence the second
row: their rigs are ~25 units tall.) Pass ``units=`` to override; the unit used is recorded in
``asset.extras`` (``source_units``, ``metres_per_unit``).
"""
from __future__ import annotations

import base64
import os

import numpy as np

from ..core.kinematics import skeleton_height
from ..core.motion import Motion
from ._common import atomic_write_bytes, file_path

__all__ = ["write_gltf", "motion_to_gltf", "metres_per_unit", "UNITS"]

#: Named units and their length in metres (``units=`` of :func:`write_gltf`).
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001, "inches": 0.0254, "cmu": 0.0254 / 0.45}

# (upper bound on the rest height in file units, unit name): the table in the module docstring
_HEIGHT_RULE = ((3.0, "m"), (38.0, "cmu"), (100.0, "inches"), (400.0, "cm"), (np.inf, "mm"))

_FLOAT, _UBYTE, _USHORT = 5126, 5121, 5123  # glTF componentType codes


def _pygltflib():
    """pygltflib, imported on first export (it takes ~0.6 s to import; ``import stagger_nb`` stays fast)."""
    import pygltflib
    return pygltflib


def metres_per_unit(motion: Motion, units="auto") -> tuple[str, float]:
    """``(unit name, metres per file unit)`` for ``motion``: by the height rule of the module docstring when
    ``units == "auto"``, else the named unit (one of :data:`UNITS`) or a positive number of metres per unit."""
    if isinstance(units, str):
        if units == "auto":
            h = skeleton_height(motion)
            name = next(n for bound, n in _HEIGHT_RULE if h <= bound)
            return name, UNITS[name]
        if units not in UNITS:
            raise ValueError(f"units: expected 'auto', one of {', '.join(UNITS)} or a number, got {units!r}")
        return units, UNITS[units]
    try:
        scale = float(units)
    except (TypeError, ValueError):
        raise ValueError(f"units: expected 'auto', a unit name or a number, got {units!r}") from None
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"units: metres per unit must be a positive finite number, got {units!r}")
    return "custom", scale


class _Blob:
    """The one binary buffer: appends 4-byte aligned arrays, each as its own bufferView + accessor."""

    def __init__(self, doc):
        self.doc, self.parts, self.size = doc, [], 0

    def add(self, array: np.ndarray, ctype: int, atype: str, *, target=None, bounds=False) -> int:
        gl = _pygltflib()
        data = np.ascontiguousarray(array).tobytes()
        self.doc.bufferViews.append(gl.BufferView(buffer=0, byteOffset=self.size, byteLength=len(data),
                                                  target=target))
        pad = -len(data) % 4
        self.parts.append(data + b"\0" * pad)
        self.size += len(data) + pad
        flat = np.asarray(array).reshape(len(array), -1)
        acc = gl.Accessor(bufferView=len(self.doc.bufferViews) - 1, componentType=ctype, count=len(array),
                          type=atype)
        if bounds:  # required for POSITION and animation inputs (spec §3.6.2.5, §3.11.2)
            acc.min = [float(v) for v in flat.min(axis=0)]
            acc.max = [float(v) for v in flat.max(axis=0)]
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def bytes(self) -> bytes:
        return b"".join(self.parts)


def _continuous(q: np.ndarray) -> np.ndarray:
    """Unit quaternions ``(F, J, 4)`` with each frame in the previous frame's hemisphere (q ≡ -q), so linear
    (slerp) sampling between keys takes the short way."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    if len(q) > 1:
        flip = np.einsum("fjc,fjc->fj", q[1:], q[:-1]) < 0
        sign = np.concatenate([np.ones((1,) + flip.shape[1:]), np.where(np.cumsum(flip, axis=0) % 2, -1.0, 1.0)])
        q = q * sign[..., None]
    return q


def motion_to_gltf(motion: Motion, units="auto") -> tuple:
    """The glTF document (buffer 0 without data) and its binary buffer for ``motion``; see the module
    docstring for the layout and the unit rule. Lengths in the output are metres.

    Returns ``(doc, data)``: a ``pygltflib.GLTF2`` and the bytes of its one buffer.
    """
    gl = _pygltflib()
    if not isinstance(motion, Motion):
        raise ValueError(f"motion: expected a Motion, got {type(motion).__name__}")
    unit_name, scale = metres_per_unit(motion, units)
    skel = motion.skeleton
    F, J = motion.num_frames, motion.num_joints
    parents = np.asarray(skel.parents)
    offsets = np.asarray(skel.offsets, dtype=float) * scale  # (J, 3) metres
    rest = np.zeros((J, 3))  # rest-pose world positions (identity rotations), metres
    for j in range(J):
        rest[j] = offsets[j] + (rest[parents[j]] if parents[j] >= 0 else 0.0)

    doc = gl.GLTF2(asset=gl.Asset(version="2.0", generator="stagger_nb",
                                  extras={"source_units": unit_name, "metres_per_unit": scale}))
    blob = _Blob(doc)
    children = [[] for _ in range(J)]
    for j in range(J):
        if parents[j] >= 0:
            children[parents[j]].append(j)
    for j in range(J):
        doc.nodes.append(gl.Node(name=str(skel.names[j]), translation=[float(v) for v in offsets[j]],
                                 children=children[j] or []))
    roots = [j for j in range(J) if parents[j] < 0]

    # the skin: inverse bind matrices are translations by -rest (rest rotations are identity), column-major
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, 3, :3] = -rest  # column-major storage: the translation is the 4th column = 4th stored row
    doc.skins.append(gl.Skin(name="skeleton", joints=list(range(J)), skeleton=roots[0] if len(roots) == 1 else None,
                             inverseBindMatrices=blob.add(ibm.reshape(J, 16).astype(np.float32), _FLOAT, gl.MAT4)))

    # a small skinned mesh: one triangle per joint at its rest position, weight 1 to that joint
    size = 0.02 * max(float(np.ptp(rest, axis=0).max()), 1e-3)
    tri = np.array([[size, 0.0, 0.0], [0.0, size, 0.0], [0.0, 0.0, size]])
    verts = (rest[:, None, :] + tri[None]).reshape(-1, 3).astype(np.float32)
    joints = np.zeros((3 * J, 4), dtype=np.uint8 if J < 256 else np.uint16)
    joints[:, 0] = np.repeat(np.arange(J), 3)
    weights = np.zeros((3 * J, 4), dtype=np.float32)
    weights[:, 0] = 1.0
    attrs = gl.Attributes(
        POSITION=blob.add(verts, _FLOAT, gl.VEC3, target=gl.ARRAY_BUFFER, bounds=True),
        JOINTS_0=blob.add(joints, _UBYTE if J < 256 else _USHORT, gl.VEC4, target=gl.ARRAY_BUFFER),
        WEIGHTS_0=blob.add(weights, _FLOAT, gl.VEC4, target=gl.ARRAY_BUFFER))
    doc.meshes.append(gl.Mesh(name="joint_markers", primitives=[gl.Primitive(attributes=attrs, mode=gl.TRIANGLES)]))
    doc.nodes.append(gl.Node(name="skin_mesh", mesh=0, skin=0))
    doc.scenes.append(gl.Scene(nodes=roots + [J]))
    doc.scene = 0

    # the animation: linear keys at the frame times
    times = (np.arange(F) * float(motion.frame_time)).astype(np.float32)
    t_acc = blob.add(times, _FLOAT, gl.SCALAR, bounds=True)
    quats = _continuous(np.asarray(motion.local_quats, dtype=float)).astype(np.float32)
    trans = motion.translations() * scale  # (F, J, 3) metres, root row = root positions
    # animated: the root, and every joint whose translation ever differs from its node's rest translation
    # (position channels replace the OFFSET: a constant channel value other than the OFFSET counts too)
    moving = [0] + [j for j in range(1, J) if motion.local_translations is not None
                    and np.any(trans[:, j] != offsets[j])]
    anim = gl.Animation(name="motion")
    for j in range(J):
        anim.samplers.append(gl.AnimationSampler(input=t_acc, output=blob.add(quats[:, j], _FLOAT, gl.VEC4),
                                                 interpolation=gl.ANIM_LINEAR))
        anim.channels.append(gl.AnimationChannel(sampler=len(anim.samplers) - 1,
                                                 target=gl.AnimationChannelTarget(node=j, path=gl.ROTATION)))
    for j in moving:
        anim.samplers.append(gl.AnimationSampler(
            input=t_acc, output=blob.add(trans[:, j].astype(np.float32), _FLOAT, gl.VEC3),
            interpolation=gl.ANIM_LINEAR))
        anim.channels.append(gl.AnimationChannel(sampler=len(anim.samplers) - 1,
                                                 target=gl.AnimationChannelTarget(node=j, path=gl.TRANSLATION)))
    doc.animations.append(anim)
    data = blob.bytes()
    doc.buffers.append(gl.Buffer(byteLength=len(data)))
    return doc, data


def write_gltf(motion: Motion, path, units="auto") -> None:
    """Write ``motion`` as glTF 2.0, atomically: binary ``.glb``, or ``.gltf`` JSON with the buffer embedded
    as a base64 data URI (one self-contained file).

    Parameters
    ----------
    motion : Motion
        F frames, J joints; exported as J skinned joint nodes and one animation (module docstring).
    path : str or os.PathLike
        Ends in ``.glb`` or ``.gltf``.
    units : "auto", one of :data:`UNITS`, or float
        The motion's length unit (metres per unit as a number); "auto" uses the height rule.
    """
    if not isinstance(motion, Motion):
        raise ValueError(f"motion must be a stagger_nb Motion, got {type(motion).__name__}")
    path = os.fsdecode(file_path(path, "path"))
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".glb", ".gltf"):
        raise ValueError(f"path: {path} must end in .glb or .gltf")
    doc, data = motion_to_gltf(motion, units)
    if ext == ".glb":
        doc.set_binary_blob(data)
        out = b"".join(doc.save_to_bytes())
    else:
        doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(data).decode("ascii")
        out = doc.gltf_to_json(separators=(",", ":"), indent=None).encode("utf-8")
    atomic_write_bytes(path, out)
