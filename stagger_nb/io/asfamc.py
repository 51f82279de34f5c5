"""CMU / Acclaim ASF (skeleton) + AMC (motion) reader.

The Acclaim model (column vectors; ``Rx``, ``Ry``, ``Rz`` the elementary rotations):

* each bone ``b`` has a rest direction ``d_b`` (unit vector, world frame), a ``length`` and an
  ``axis a1 a2 a3 ORDER`` line giving its local frame ``C_b = R_ORDER[2](a3) R_ORDER[1](a2) R_ORDER[0](a1)``
  (the first listed axis is applied first; ``axis 0 0 20 XYZ`` is ``Rz(20) Ry(0) Rx(0)``);
* an AMC frame gives values for the bone's ``dof`` (e.g. ``rx ry rz``), composed the same way:
  ``M_b = ... R_dof2 R_dof1`` (first listed dof applied first);
* the bone's world rotation is ``W_b = W_parent C_b M_b C_b^-1`` and its end point is
  ``e_b = e_parent + W_b (length_b * d_b)``; the root's ``W_root = C_root M_root C_root^-1`` with
  ``C_root`` from ``:root orientation`` / ``axis`` and ``M_root`` from the root's rotation channels,
  and ``e_root`` is the root's translation channels (``TX TY TZ``).

Conversion to :class:`~stagger_nb.core.Motion`: one joint ``"root"`` plus one joint per bone, in
depth-first hierarchy order. The joint of bone ``b`` sits at the bone's start (its parent's end), so
its OFFSET is the parent bone's vector ``length_p * d_p`` (zero below the root), a leaf bone gets an
``End Site`` at its own vector, and the rest pose has identity rotations everywhere. The local rotation
of joint ``b`` is then ``C_b M_b C_b^-1``. Channels are laid out for BVH writing as
``Zrotation Yrotation Xrotation`` (= ``Rz Ry Rx``, the CMU convention), the root adding
``Xposition Yposition Zposition`` first.

Units: lengths and root translations are kept in file units by default (as the common CMU BVH
conversions do); ``units="inches"`` or ``"meters"`` rescale using ``:units length L`` (CMU: file
length = inches * L). Angles follow ``:units angle deg|rad`` (AMC ``:DEGREES`` / ``:RADIANS`` override
for the motion file).
"""
from __future__ import annotations

import re

import numpy as np

from ..core.motion import MAX_FRAME_JOINTS, Motion, check_frame_time
from ..core.rotations import quat_conj, quat_mul
from ..core.skeleton import Skeleton
from ._common import MAX_TOKEN, FormatError, euler_deg_to_quat, file_path, finite_number, read_text, split_values

__all__ = ["AMCError", "read_asf_amc", "parse_asf", "parse_amc", "AsfSkeleton"]

_MAX_BONES = 10_000
#: A comment: '#' at the start of a line or of a token, to the end of the line. Inside a token it is part of
#: the token, so MSVC's ``1.#INF`` is a bad number (not ``1.`` and a comment).
_COMMENT = re.compile(r"(?:^|(?<=\s))#.*", re.DOTALL)
_MAX_FRAMES = 10_000_000
_ROT_DOFS = ("rx", "ry", "rz")
_TRANS_DOFS = ("tx", "ty", "tz")
_UNIT_SCALE = {"file": None, "inches": 1.0, "meters": 0.0254}


class AMCError(FormatError):
    """A malformed ASF or AMC file; the message names the file, the line and what was expected."""


class _Bone:
    __slots__ = ("name", "direction", "length", "axis_angles", "axis_order", "dof", "line")

    def __init__(self, line: int):
        self.name = None
        self.direction = None
        self.length = None
        self.axis_angles = (0.0, 0.0, 0.0)
        self.axis_order = "XYZ"
        self.dof = ()
        self.line = line


class AsfSkeleton:
    """Parsed ASF content (file units, angles in degrees).

    Attributes
    ----------
    length_scale : float
        ``:units length`` (file length = inches * length_scale for CMU).
    angle_unit : str
        ``"deg"`` or ``"rad"``.
    root_order : tuple[str, ...]
        Root channels in AMC order, lower case, e.g. ``("tx", "ty", "tz", "rx", "ry", "rz")``.
    root_axis : str
        Order of the root orientation angles, e.g. ``"XYZ"``.
    root_position, root_orientation : ndarray, shape (3,)
        Rest root position (file units) and orientation angles (degrees).
    bones : list
        Bones in depth-first hierarchy order; each has ``name``, ``direction (3,)``, ``length``,
        ``axis_angles (3,)`` degrees, ``axis_order`` and ``dof`` (tuple of ``rx``/``ry``/``rz``).
    parents : list[int]
        Parent of each bone in ``bones`` (``-1`` = the root).
    """

    def __init__(self, length_scale, angle_unit, root_order, root_axis, root_position, root_orientation,
                 bones, parents):
        self.length_scale = length_scale
        self.angle_unit = angle_unit
        self.root_order = root_order
        self.root_axis = root_axis
        self.root_position = root_position
        self.root_orientation = root_orientation
        self.bones = bones
        self.parents = parents


def _iter_lines(text: str, limit: int | None = None):
    """``(line number, line)`` pairs of ``text`` one at a time (``\\n``, ``\\r\\n`` or lone ``\\r`` breaks),
    so a file of millions of empty lines is never held as a list; with ``limit``, only the first ``limit``
    characters of each line (a line of millions of values is not copied whole)."""
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    pos, ln, n = 0, 0, len(text)
    while pos < n:
        nl = text.find("\n", pos)
        end = n if nl < 0 else nl
        ln += 1
        yield ln, text[pos:end if limit is None else min(end, pos + limit)]
        pos = end + 1


def _floats(toks: list[str], n: int, what: str, source: str, ln: int) -> list[float]:
    if len(toks) != n:
        raise AMCError(source, ln, f"expected {n} numbers for {what}, found {len(toks)}")
    return [finite_number(t, what, source, ln, AMCError) for t in toks]


def _axis_order(tok: str, source: str, ln: int) -> str:
    o = tok.upper()
    if len(o) != 3 or sorted(o) != ["X", "Y", "Z"]:
        raise AMCError(source, ln, f"expected an axis order such as XYZ, found {tok!r}")
    return o


def parse_asf(text: str, source: str = "<asf>") -> AsfSkeleton:
    """Parse ASF text (see the module docstring); raises :class:`AMCError` naming file and line."""
    length_scale, angle_unit = 1.0, "deg"
    root_order, root_axis = ("tx", "ty", "tz", "rx", "ry", "rz"), "XYZ"
    root_pos, root_ori = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    bones: dict[str, _Bone] = {}
    bone_list: list[_Bone] = []
    children: dict[str, list[str]] = {}
    child_line: dict[str, int] = {}
    section = None
    bone = None
    in_hier = False
    seen_root = seen_bonedata = seen_hierarchy = False
    seen_sections: dict[str, int] = {}
    ln = 0
    for ln, raw in _iter_lines(text):
        line = _COMMENT.sub("", raw).strip()
        if not line:
            continue
        toks = line.split()
        key = toks[0].lower()
        if section is None and not key.startswith(":"):  # not quoted: a text file's first words are not shown
            raise AMCError(source, ln, "not an ASF file: expected a ':version', ':name' or other ':' keyword line "
                                       "first (the line is not quoted here)")
        if key.startswith(":"):
            if key in (":units", ":root", ":bonedata", ":hierarchy") and key in seen_sections:
                raise AMCError(source, ln, f"a second {toks[0]!r} section (the first is on line "
                                           f"{seen_sections[key]})")
            seen_sections.setdefault(key, ln)
            if bone is not None:
                raise AMCError(source, ln, f"expected 'end' closing bone {bone.name or '?'} before {toks[0]!r}")
            if section == "hierarchy" and in_hier:
                raise AMCError(source, ln, f"expected 'end' closing ':hierarchy' before {toks[0]!r}")
            section = key[1:]
            if section == "root":
                seen_root = True
            elif section == "bonedata":
                seen_bonedata = True
            elif section == "hierarchy":
                seen_hierarchy = True
            continue
        if section == "units":
            if key == "length":
                (length_scale,) = _floats(toks[1:], 1, "':units length'", source, ln)
                if length_scale <= 0:
                    raise AMCError(source, ln, f"expected a positive ':units length', found {toks[1]!r}")
            elif key == "angle":
                if len(toks) != 2 or toks[1].lower() not in ("deg", "rad"):
                    raise AMCError(source, ln, f"expected 'angle deg' or 'angle rad', found {line!r}")
                angle_unit = toks[1].lower()
            # 'mass' and anything else is irrelevant to kinematics
        elif section == "root":
            if key == "order":
                order = tuple(t.lower() for t in toks[1:])
                bad = [t for t in order if t not in _ROT_DOFS + _TRANS_DOFS]
                if bad or len(set(order)) != len(order):
                    raise AMCError(source, ln, f"expected root channels among TX TY TZ RX RY RZ (each once), "
                                               f"found {' '.join(toks[1:])!r}")
                root_order = order
            elif key == "axis":
                if len(toks) != 2:
                    raise AMCError(source, ln, f"expected 'axis XYZ' for the root, found {line!r}")
                root_axis = _axis_order(toks[1], source, ln)
            elif key == "position":
                root_pos = _floats(toks[1:], 3, "the root position", source, ln)
            elif key == "orientation":
                root_ori = _floats(toks[1:], 3, "the root orientation", source, ln)
            else:
                raise AMCError(source, ln, f"expected order/axis/position/orientation in ':root', found {toks[0]!r}")
        elif section == "bonedata":
            if bone is None:
                if key != "begin":
                    raise AMCError(source, ln, f"expected 'begin' of a bone, found {toks[0]!r}")
                if len(bone_list) >= _MAX_BONES:
                    raise AMCError(source, ln, f"more than {_MAX_BONES} bones")
                bone = _Bone(ln)
                continue
            if key == "end":
                for attr, what in (("name", "name"), ("direction", "direction"), ("length", "length")):
                    if getattr(bone, attr) is None:
                        raise AMCError(source, ln, f"bone begun on line {bone.line} has no '{what}'")
                if bone.name in bones or bone.name == "root":
                    raise AMCError(source, bone.line, f"bone name {bone.name!r} used twice")
                bones[bone.name] = bone
                bone_list.append(bone)
                bone = None
            elif key == "name":
                if len(toks) != 2:
                    raise AMCError(source, ln, f"expected 'name <bone>', found {line!r}")
                bone.name = toks[1]
            elif key == "direction":
                # used as written (not re-normalised), as other Acclaim readers and CMU BVH conversions do
                bone.direction = np.array(_floats(toks[1:], 3, "the bone direction", source, ln))
            elif key == "length":
                (bone.length,) = _floats(toks[1:], 1, "the bone length", source, ln)
                if bone.length < 0:
                    raise AMCError(source, ln, f"expected a non-negative bone length, found {toks[1]!r}")
            elif key == "axis":
                if len(toks) != 5:
                    raise AMCError(source, ln, f"expected 'axis <a1> <a2> <a3> <ORDER>', found {line!r}")
                bone.axis_angles = tuple(_floats(toks[1:4], 3, "the bone axis", source, ln))
                bone.axis_order = _axis_order(toks[4], source, ln)
            elif key == "dof":
                dof = tuple(t.lower() for t in toks[1:])
                bad = [t for t in dof if t not in _ROT_DOFS]
                if bad:
                    raise AMCError(source, ln, f"unsupported dof {bad[0]!r} (only rx, ry, rz are read for bones)")
                if len(set(dof)) != len(dof):
                    raise AMCError(source, ln, f"repeated dof in {' '.join(toks[1:])!r}")
                bone.dof = dof
            # id, limits (and their continuation lines), bodymass, cofmass: not needed
        elif section == "hierarchy":
            if not in_hier:
                if key != "begin":
                    raise AMCError(source, ln, f"expected 'begin' in ':hierarchy', found {toks[0]!r}")
                in_hier = True
                continue
            if key == "end":
                in_hier = False
                section = "hierarchy-done"
                continue
            parent = toks[0]
            if parent != "root" and parent not in bones:
                raise AMCError(source, ln, f"unknown parent {parent!r} in ':hierarchy' (expected root or a bone name)")
            for c in toks[1:]:
                if c not in bones:
                    raise AMCError(source, ln, f"unknown bone {c!r} in ':hierarchy'")
                if c in child_line:
                    raise AMCError(source, ln, f"bone {c!r} already has a parent (line {child_line[c]})")
                child_line[c] = ln
                children.setdefault(parent, []).append(c)
        elif section == "hierarchy-done":
            raise AMCError(source, ln, f"unexpected {toks[0]!r} after the ':hierarchy' 'end'")
        # other sections (:version, :name, :documentation, unknown) are free text
    last = ln or 1
    if bone is not None:
        raise AMCError(source, last, f"file ends early: expected 'end' of the bone begun on line {bone.line}")
    if in_hier:
        raise AMCError(source, last, "file ends early: expected 'end' of ':hierarchy'")
    for flag, what in ((seen_root, ":root"), (seen_bonedata, ":bonedata"), (seen_hierarchy, ":hierarchy")):
        if not flag:
            raise AMCError(source, last, f"no '{what}' section found")
    # depth-first order from the root; the hierarchy is a tree because each bone has one parent line
    order, parents = [], []
    stack = [(c, -1) for c in reversed(children.get("root", []))]
    while stack:
        name, p = stack.pop()
        k = len(order)
        order.append(bones[name])
        parents.append(p)
        stack.extend((c, k) for c in reversed(children.get(name, [])))
    if len(order) != len(bone_list):
        missing = [b.name for b in bone_list if b.name not in {o.name for o in order}]
        raise AMCError(source, bones[missing[0]].line,
                       f"bone {missing[0]!r} is not connected to the root in ':hierarchy'")
    return AsfSkeleton(length_scale, angle_unit, root_order, root_axis, np.array(root_pos),
                       np.array(root_ori), order, parents)


def parse_amc(text: str, asf: AsfSkeleton, source: str = "<amc>"):
    """Parse AMC text against a parsed ASF.

    Returns
    -------
    root : ndarray, shape (F, len(asf.root_order))
        Root channel values in ``asf.root_order`` (angles in degrees).
    dofs : list of ndarray, one per bone in ``asf.bones``, shape (F, len(bone.dof)), degrees.
    """
    to_deg = asf.angle_unit == "rad"
    names = {"root": len(asf.root_order)}
    col = {"root": 0}
    width = len(asf.root_order)
    bone_cols = []
    for b in asf.bones:
        if b.dof:
            names[b.name] = len(b.dof)
            col[b.name] = width
            bone_cols.append(width)
            width += len(b.dof)
        else:
            bone_cols.append(None)
    need = len(names)
    rows: list[list[str]] = []  # per frame: the value tokens laid out by `col`
    frame_lines: list[int] = []
    current = None
    seen: set = set()
    expect_no = None
    header_seen = False
    ln = 0
    longest = (width + 2) * (MAX_TOKEN + 1)  # characters of a line that can matter: the rest is an error
    for ln, raw in _iter_lines(text, longest):
        s = raw.strip()
        if not s or s[0] == "#":
            continue
        if s[0] == ":":
            header_seen = True
            if current is not None:
                raise AMCError(source, ln, f"unexpected header {s!r} inside frame data")
            kw = s.upper()
            if kw == ":DEGREES":
                to_deg = False
            elif kw == ":RADIANS":
                to_deg = True
            continue
        toks = s.split(None, 1)  # the head, then the values split below with a bound
        head = toks[0]
        if len(toks) == 1 and head.isascii() and head.isdigit():  # '¹', '١' are digits to isdigit()
            if current is not None and len(seen) != need:
                missing = next(n for n in names if n not in seen)
                raise AMCError(source, ln, f"frame {expect_no - 1} has no line for {missing!r}")
            if len(head) > 18:  # also keeps int() from its 4,300-digit ValueError
                raise AMCError(source, ln, f"frame number {head[:20]}... has {len(head)} digits")
            no = int(head)
            if expect_no is not None and no != expect_no:
                raise AMCError(source, ln, f"expected frame number {expect_no}, found {no}")
            if len(rows) >= _MAX_FRAMES or (len(rows) + 1) * (len(asf.bones) + 1) > MAX_FRAME_JOINTS:
                raise AMCError(source, ln, f"more than {min(_MAX_FRAMES, MAX_FRAME_JOINTS // (len(asf.bones) + 1))}"
                                           f" frames of {len(asf.bones) + 1} joints")
            expect_no = no + 1
            current = [None] * width
            rows.append(current)
            frame_lines.append(ln)
            seen = set()
            continue
        if current is None:
            if not (rows or header_seen):  # nothing yet says this is an AMC file: its words are not quoted
                raise AMCError(source, ln, "not an AMC file: expected ':FULLY-SPECIFIED', ':DEGREES' or a frame "
                                           "number first (the line is not quoted here)")
            raise AMCError(source, ln, f"expected a frame number, found {head!r}")
        n = names.get(head)
        if n is None:
            raise AMCError(source, ln, f"unknown bone {head!r} (expected root or a bone with dof)")
        if head in seen:
            raise AMCError(source, ln, f"second line for {head!r} in frame {expect_no - 1}")
        vals = split_values(toks[1] if len(toks) > 1 else "", n, len(raw) == longest, f"for {head!r}", source, ln,
                            AMCError)
        seen.add(head)
        c = col[head]
        current[c:c + n] = vals
    if current is None:
        raise AMCError(source, ln or 1, "no frames found (expected a frame number line)")
    if len(seen) != need:
        missing = next(n for n in names if n not in seen)
        raise AMCError(source, ln, f"file ends early: frame {expect_no - 1} has no line for {missing!r}")
    flat = [t for r in rows for t in r]
    joined = "".join(flat)
    # numpy, like float, reads '1_000' and non-ASCII digits: such tokens go to the checked path
    ok = joined.isascii() and "_" not in joined
    if ok:
        try:
            data = np.array(flat, dtype=float).reshape(len(rows), width)
            ok = bool(np.all(np.isfinite(data)))
        except ValueError:
            ok = False
    if not ok:
        _locate_bad_number(text, frame_lines, source)
    if to_deg:
        rot = np.array([t.startswith("r") for t in asf.root_order] + [True] * (width - len(asf.root_order)))
        data = np.where(rot, np.degrees(data), data)
    root = data[:, :len(asf.root_order)]
    dofs = [data[:, c:c + len(b.dof)] if c is not None else np.zeros((len(rows), 0))
            for b, c in zip(asf.bones, bone_cols)]
    return root, dofs


def _locate_bad_number(text, frame_lines, source):
    for ln, line in _iter_lines(text):
        if ln < frame_lines[0]:
            continue
        toks = line.split()
        if len(toks) < 2 or toks[0].startswith("#"):
            continue
        for t in toks[1:]:
            finite_number(t, repr(toks[0]), source, ln, AMCError)
    raise AMCError(source, None, "a value could not be read")  # unreachable: the fast path failed somewhere


def _compose(axes: str, angles_deg) -> np.ndarray:
    """Acclaim composition ``R_axes[-1] ... R_axes[0]`` (first listed axis applied first, i.e. extrinsic)
    of angles in degrees ``(..., len(axes))`` -> quaternions ``(..., 4)`` (x, y, z, w)."""
    return euler_deg_to_quat(np.asarray(angles_deg, dtype=float)[..., ::-1], axes[::-1])


def _conjugate_by(c: np.ndarray, m: np.ndarray) -> np.ndarray:
    """``C M C^-1`` for a quaternion ``c (4,)`` and ``m (F, 4)``."""
    return quat_mul(quat_mul(c, m), quat_conj(c))


def asf_amc_to_motion(asf: AsfSkeleton, root: np.ndarray, dofs: list, frame_time: float,
                      units: str = "file") -> Motion:
    """Build the :class:`Motion` described in the module docstring from parsed ASF/AMC arrays."""
    if units not in _UNIT_SCALE:
        raise ValueError(f"units must be one of {', '.join(_UNIT_SCALE)}, got {units!r}")
    s = 1.0 if _UNIT_SCALE[units] is None else _UNIT_SCALE[units] / asf.length_scale
    F = root.shape[0]
    B = len(asf.bones)
    vec = np.array([b.direction * b.length for b in asf.bones]).reshape(B, 3) * s
    names = ["root"] + [b.name for b in asf.bones]
    parents = np.array([-1] + [p + 1 for p in asf.parents])
    offsets = np.zeros((B + 1, 3))
    has_child = np.zeros(B + 1, dtype=bool)
    for k, p in enumerate(asf.parents):
        j = k + 1
        if p >= 0:
            offsets[j] = vec[p]
        has_child[p + 1] = True
    end_sites = {k + 1: vec[k] for k in range(B) if not has_child[k + 1]}
    channels = [("Xposition", "Yposition", "Zposition", "Zrotation", "Yrotation", "Xrotation")] + \
               [("Zrotation", "Yrotation", "Xrotation")] * B
    skel = Skeleton(names, parents, offsets, tuple(channels), end_sites)

    quats = np.empty((F, B + 1, 4))
    # root
    c_root = _compose(asf.root_axis, asf.root_orientation)
    rot_idx = [i for i, t in enumerate(asf.root_order) if t.startswith("r")]
    rot_axes = "".join(asf.root_order[i][1] for i in rot_idx)
    m_root = _compose(rot_axes, root[:, rot_idx])
    quats[:, 0] = _conjugate_by(c_root, m_root)
    pos = np.broadcast_to(asf.root_position * s, (F, 3)).copy()
    for i, t in enumerate(asf.root_order):
        if t.startswith("t"):
            pos[:, "xyz".index(t[1])] = root[:, i] * s
    for k, b in enumerate(asf.bones):
        c = _compose(b.axis_order, np.array(b.axis_angles))
        if b.dof:
            m = _compose("".join(d[1] for d in b.dof), dofs[k])
            quats[:, k + 1] = _conjugate_by(c, m)
        else:
            quats[:, k + 1] = [0.0, 0.0, 0.0, 1.0]
    return Motion(skel, frame_time, pos, quats)


def read_asf_amc(asf_path, amc_path, frame_time: float = 1 / 120, units: str = "file") -> Motion:
    """Read a CMU/Acclaim skeleton (``.asf``) and motion (``.amc``) into a :class:`Motion`.

    Parameters
    ----------
    asf_path, amc_path : path-like
    frame_time : float
        Seconds between AMC frames (AMC files do not store it; CMU captured at 120 Hz).
    units : {"file", "inches", "meters"}
        ``"file"`` keeps the ASF's units (CMU: inches * 0.45, as the usual CMU BVH conversions do).

    Returns
    -------
    Motion
        ``root_positions (F, 3)``, ``local_quats (F, 1 + bones, 4)`` (x, y, z, w); joint 0 is
        ``"root"``, the others are the ASF bones in depth-first order (see the module docstring).

    Raises
    ------
    AMCError
        (a ``ValueError``) naming the file, line and what was expected, for malformed input.
    ValueError
        For a bad ``frame_time`` or ``units``.
    """
    ft = check_frame_time(frame_time)
    if units not in _UNIT_SCALE:
        raise ValueError(f"units must be one of {', '.join(_UNIT_SCALE)}, got {units!r}")
    asf_path, amc_path = file_path(asf_path, "asf_path"), file_path(amc_path, "amc_path")
    asf = parse_asf(read_text(asf_path, AMCError), asf_path)
    root, dofs = parse_amc(read_text(amc_path, AMCError), asf, amc_path)
    return asf_amc_to_motion(asf, root, dofs, ft, units)
