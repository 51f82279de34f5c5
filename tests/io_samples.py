"""Tiny sample files the io tests share: an ASF/AMC pair and a two-joint BVH text."""
from __future__ import annotations

TINY_ASF = """# tiny test skeleton
:version 1.10
:name TINY
:units
  mass 1.0
  length 1
  angle deg
:documentation
  free text: begin end :: nothing here is parsed
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 0 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name a
     direction 0 1 0
     length 2
     axis 0 0 0  XYZ
    dof rz
    limits (-180.0 180.0)
  end
  begin
     id 2
     name b
     direction 1 0 0
     length 1
     axis 0 0 90 XYZ
    dof rx
    limits (-180.0 180.0)
  end
:hierarchy
  begin
    root a
    a b
  end
"""


TINY_AMC = """# tiny motion
:FULLY-SPECIFIED
:DEGREES
1
root 1 2 3 0 0 0
a 90
b 90
2
root 0 0 0 0 0 0
b 0
a 0
"""


TINY = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Chest
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 5 0
    }
  }
  JOINT Leg
  {
    OFFSET 3 0 0
    CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 -8 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
1 2 3 90 0 0 0 0 0 4 0 0 0 0 0
0 0 0 0 0 0 0 90 0 0 0 0 0 0 0
"""


# builders of the hand-written hierarchies the hostile sets start from (tests/hostile_corpus.py,
# tests/test_hostile_heldout.py, benchmarks/hostile_heldout.py): each set writes its own small rig and then
# breaks it by text replacement, so the text is built to the letter (tabs, line numbers) of a file written by hand
ZXY = "Zrotation Xrotation Yrotation"
ROOT_CHANNELS = "Xposition Yposition Zposition " + ZXY


def bvh_hierarchy(root, tab: str = "\t") -> str:
    """The HIERARCHY part of a BVH text (up to ``MOTION``) of the nested joints ``(name, offset, below)`` or
    ``(name, offset, below, channels)``: ``below`` the child joints (a list) or, for a leaf, its End Site's offset
    (a string); ``channels`` by default :data:`ROOT_CHANNELS` for the root, :data:`ZXY` below it. One ``tab`` per
    depth."""
    lines = ["HIERARCHY"]

    def joint(node, depth: int) -> None:
        name, offset, below, *channels = node
        chans = channels[0] if channels else (ROOT_CHANNELS if depth == 0 else ZXY)
        pad, inner = tab * depth, tab * (depth + 1)
        lines.extend([f"{pad}{'JOINT' if depth else 'ROOT'} {name}", pad + "{", f"{inner}OFFSET {offset}",
                      f"{inner}CHANNELS {len(chans.split())} {chans}"])
        if isinstance(below, str):
            lines.extend([f"{inner}End Site", inner + "{", f"{inner}{tab}OFFSET {below}", inner + "}"])
        else:
            for child in below:
                joint(child, depth + 1)
        lines.append(pad + "}")

    joint(root, 0)
    return "\n".join(lines) + "\n"


FEMUR_LIMITS = ("(-160.0 20.0)", "(-70.0 70.0)", "(-60.0 70.0)")   # a CMU femur's rx ry rz limits
ASF_ROOT = ":root\n  order TX TY TZ RX RY RZ\n  axis XYZ\n  position 0 0 0\n  orientation 0 0 0\n"


def asf_bone(id: int, name: str, direction: str, length, axis: str, dof: str = "", limits=()) -> str:
    """One ``begin .. end`` block of an ASF ``:bonedata`` section (``limits``: one ``(lo hi)`` text per dof)."""
    rows = [f"    id {id}", f"    name {name}", f"    direction {direction}", f"    length {length}",
            f"    axis {axis}"] + ([f"    dof {dof}"] if dof else [])
    rows += [("    limits " if i == 0 else "           ") + lim for i, lim in enumerate(limits)]
    return "  begin\n" + "\n".join(rows) + "\n  end\n"


def line_of(text: str, needle: str) -> int:
    """The number (1-based) of the first line of ``text`` holding ``needle``: where an error should point."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)
