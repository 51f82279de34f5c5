"""What a :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` sends to the browser (a mixin of the view, one
job: turning its motion, ghost, highlights, camera, trails, ground and legend into the conductor's synced
buffers and the pythreejs models). Every number comes from :mod:`stagger_nb.scene3d`; nothing here is
recomputed per frame (the browser's clock does that)."""
from __future__ import annotations

import html

import numpy as np
import pythreejs as three

from .. import scene3d
from ..core.motion import Motion
from ._skeleton_parts import _CONTACT, _GHOST, _JOINT, _PALETTE, _POSE, _SELECTED, _TEMPLATE, _TRAILS, _attr, _f32, _rgb


class _SceneSender:
    """The sending half of :class:`~stagger_nb.widgets.skeleton_view.SkeletonView` (its state lives in the view)."""

    def _constant_arrays(self):
        """The mesh's attribute arrays as the kernel holds them, (V, 3) float32 each: positions zero (the browser's
        clock writes every shown frame's, ``_skeleton_mesh.js``), the spheres' normals (the unit sphere's) and the
        constant colours (joints plain, bones by side). Sent once, with the mesh; never per edit."""
        return scene3d.mesh_constants(len(self._names), self._segs, _TEMPLATE, _PALETTE[0], self._bone_colours)

    @staticmethod
    def _contact_list(contacts, motion):
        sk = motion.skeleton
        return [(sk.index(n) if isinstance(n, str) else int(n), int(a), int(b)) for n, a, b in contacts]

    def _states_array(self) -> np.ndarray:
        m = self._motion
        return scene3d.joint_states(m.num_frames, m.frame_time, m.num_joints, self._pose_frames, self._contacts)

    def _push_motion(self, motion: Motion) -> None:
        F = motion.num_frames
        step, interval = self._tick(motion.frame_time)
        pts = self._points.tobytes()
        self._states = self._states_array()
        with self.hold_trait_notifications():
            if self.frame > F - 1:
                self.frame = F - 1
            states = self._states.tobytes()
            nbytes = (len(pts) if pts != self.conductor.points else 0) + \
                (len(states) if states != self.conductor.states else 0)   # traitlets sends changes only
            with self.conductor.hold_sync():
                self.conductor.points = pts
                self.conductor.num_frames = F
                self.conductor.states = states
                self.conductor.frame_time = motion.frame_time
                self.conductor.trail_window = max(1, int(round(self.trail_seconds / motion.frame_time)))
                nbytes += self._push_camera()
                nbytes += self._push_ghost()
            nbytes += self._push_trails()
            self.player.max = self.frame_slider.max = F - 1
            self.player.step, self.player.interval = step, interval
        self.edit_bytes = int(nbytes + self._update_grid())
        self._update_legend()

    def _push_ghost(self) -> int:
        """Build (first time), fill and send the ghost, only while it is shown. Returns the bytes sent."""
        if not self.show_ghost or self._ghost_motion is None:
            if self.ghost_mesh is not None:
                self.ghost_mesh.visible = False
            return 0
        nbytes = 0
        if self._ghost_points is None:
            self._ghost_points = scene3d.skeleton_points(self._ghost_motion) + self._ghost_offset.astype(np.float32)
            gp = self._ghost_points.tobytes()
            with self.conductor.hold_sync():
                self.conductor.ghost_points = gp
                self.conductor.ghost_frames = len(self._ghost_points)
            nbytes += len(gp)
        if self.ghost_mesh is None:   # the same constant arrays; the browser's clock writes its frames
            pos, nrm, _ = self._constant_arrays()
            geom = three.BufferGeometry(attributes={"position": _attr(pos), "normal": _attr(nrm)}, index=self._index)
            mat = three.MeshLambertMaterial(color=_GHOST, transparent=True, opacity=0.35, depthWrite=False)
            self.ghost_mesh = three.Mesh(geom, mat, name="ghost", frustumCulled=False)
            self.rig.children = tuple(self.rig.children) + (self.ghost_mesh,)
            self.conductor.ghost = self.ghost_mesh
            nbytes += pos.nbytes + nrm.nbytes
        self.ghost_mesh.visible = True
        return nbytes

    def _push_highlights(self) -> None:
        self._states = self._states_array()
        self.conductor.states = self._states.tobytes()
        self._update_legend()

    def _push_camera(self) -> int:
        m = self._motion
        # every point (the End Sites too: the top of the head) and the joints' spheres stay in the canvas
        cam = scene3d.follow_camera(self._points, m.frame_time, self.camera, aspect=self.width / self.height,
                                    pad=self._radius)
        self._camera = cam
        self.three_camera.fov, self.three_camera.near, self.three_camera.far = cam.fov, cam.near, cam.far
        if not getattr(self, "_camera_placed", None) == self.camera:   # keep the user's orbit across edits
            self.three_camera.position = cam.position
            self.controls.target = cam.target
            self.three_camera.quaternion = scene3d.look_at_quaternion(cam.position, cam.target)
            self._camera_placed = self.camera
        self.rig.position = tuple(-float(x) for x in cam.rig[min(self.frame, m.num_frames - 1)])
        path = _f32(-cam.rig).tobytes()
        nbytes = len(path) if path != self.conductor.rig_path else 0
        self.conductor.rig_path = path
        return nbytes

    def _push_trails(self) -> int:
        """Trails of ``trail_joints``: one LineSegments and one Points sharing a geometry of ``2 window``
        segments per joint, filled around the playhead (browser-side per frame; here for the current frame)."""
        idx = [self._names.index(n) for n in self.trail_joints]
        old = list(self.trails_group.children)
        w = self.conductor.trail_window
        if not idx:
            self.trails_group.children = ()
            self.conductor.trails = None
            self.conductor.trail_joints = []
            nbytes = 0
        else:
            seg = scene3d.trail_segments(self._points, idx, self.frame, w)
            col = np.repeat(np.asarray([_rgb(_TRAILS[i % len(_TRAILS)]) for i in range(len(idx))], np.float32),
                            4 * w, axis=0)
            geom = three.BufferGeometry(attributes={"position": _attr(seg), "color": _attr(col)})
            line = three.LineSegments(geom, three.LineBasicMaterial(vertexColors="VertexColors"),
                                      frustumCulled=False)
            dots = three.Points(geom, three.PointsMaterial(vertexColors="VertexColors", size=self._radius * 0.6),
                                frustumCulled=False)
            self.trails_group.children = (line, dots)
            with self.conductor.hold_sync():
                self.conductor.trail_joints = idx
                self.conductor.trails = line
            nbytes = seg.nbytes + col.nbytes
        for o in old:
            if isinstance(o, three.LineSegments):
                for w_ in (*o.geometry.attributes.values(), o.geometry, o.material):
                    w_.close()
            else:
                o.material.close()
            o.close()
        return nbytes

    def _update_grid(self) -> int:
        """The ground: cell-edge line segments over the clip's ground track (see scene3d.ground_segments), built at
        height 0 and lifted to the ground by the grid's position; the segments are replaced only when the extent
        changes (an edit moving the lowest point moves the grid: one small message). Returns the bytes sent."""
        lo, hi, cell = scene3d.ground_extent(self._points, scene3d.grid_cell(self._size), 2 * self._size)
        ground = (0.0, float(self._camera.ground), 0.0)
        key = (tuple(lo), tuple(hi), cell)
        if key == getattr(self, "_grid_key", None):
            if tuple(self.grid.position) != ground:
                self.grid.position = ground
            return 0
        seg = scene3d.ground_grid(lo, hi, cell, 0.0)
        if self.grid is not None and self.grid.geometry.attributes["position"].array.shape == seg.shape:
            with self.grid.hold_sync():
                self.grid.geometry.attributes["position"].array = seg   # same size: the array only, in place
                self.grid.position = ground
        else:
            old = self.grid
            self.grid = three.LineSegments(three.BufferGeometry(attributes={"position": three.BufferAttribute(seg)}),
                                           three.LineBasicMaterial(color="#cbd5e0"), name="ground", position=ground)
            self.rig.children = tuple(ch for ch in self.rig.children if ch is not old) + (self.grid,)
            if old is not None:   # its geometry, array and material too (not left behind)
                for w in (old.geometry.attributes["position"], old.geometry, old.material, old):
                    w.close()
        self._grid_key, self._grid_cell = key, cell
        return seg.nbytes

    def _update_legend(self) -> None:
        def sw(colour, label, shape="bar"):
            style = ("width:14px;height:5px;border-radius:2px" if shape == "bar" else
                     "width:9px;height:9px;border-radius:50%")
            return (f'<span style="display:inline-flex;align-items:center;margin-right:10px;white-space:nowrap">'
                    f'<span style="display:inline-block;{style};background:{colour};margin-right:4px"></span>'
                    f'{html.escape(label)}</span>')
        items = [sw(scene3d.SIDE_COLOURS["left"], "left"), sw(scene3d.SIDE_COLOURS["right"], "right"),
                 sw(scene3d.SIDE_COLOURS["centre"], "centre"), sw(_JOINT, "joint (click to select)", "dot")]
        if self._selected:
            items.append(sw(_SELECTED, "selected: " + ", ".join(self._names[j] for j in self._selected), "dot"))
        if len(self._pose_frames):
            items.append(sw(_POSE, f"{self.pose_label} ({len(self._pose_frames)})", "dot"))
        if self._contacts:
            items.append(sw(_CONTACT, "contact", "dot"))
        if self._ghost_motion is not None and self.show_ghost:   # what is drawn
            items.append(sw(_GHOST, "original (ghost)"))
        for i, n in enumerate(self.trail_joints):
            items.append(sw(_TRAILS[i % len(_TRAILS)], f"trail {n} (±{self.trail_seconds:g} s)"))
        # one unit: an entry moves to the next line whole, never split ("grid" | "square: 5 units" was seen)
        items.append(f'<span style="color:#718096;display:inline-block;white-space:nowrap">'
                     f'grid square: {getattr(self, "_grid_cell", 0):g} units</span>')
        self.legend.value = '<div style="font-size:12px;line-height:18px">' + "".join(items) + "</div>"
