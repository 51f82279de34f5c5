"""ASF (Acclaim skeleton) text -> :class:`AsfSkeleton`: units, the root's channels and rest frame, each bone's
direction, length, axis and dof, and the hierarchy (:func:`parse_asf`; the model these describe is in the
docstring of :mod:`.asfamc`). Every error is an :class:`AMCError` naming the file and line."""
from __future__ import annotations

import re

import numpy as np

from ._common import FormatError, finite_number

__all__ = ["AMCError", "AsfSkeleton", "parse_asf"]

_MAX_BONES = 10_000
#: A comment: '#' at the start of a line or of a token, to the end of the line. Inside a token it is part of
#: the token, so MSVC's ``1.#INF`` is a bad number (not ``1.`` and a comment).
_COMMENT = re.compile(r"(?:^|(?<=\s))#.*", re.DOTALL)
_ROT_DOFS = ("rx", "ry", "rz")
_TRANS_DOFS = ("tx", "ty", "tz")


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

