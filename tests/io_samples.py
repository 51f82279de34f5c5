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
