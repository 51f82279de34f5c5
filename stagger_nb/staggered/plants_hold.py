"""Holding the plants (the contact layer's core, :mod:`stagger_nb.staggered.plants`): the target of each held foot
(the source's own foot replayed on the edited timing), exact IK on the plants' frames, C1 fades of the IK
displacement around them, the root's shift, and the pop cap; the legs in the air are :mod:`.plants_air`'s, the
sampling helpers :mod:`.plants_sample`'s, what is read of the source :mod:`.plants_source`'s, the turn-rate
allowances :mod:`.plants_rate`'s.
"""
from __future__ import annotations

import numpy as np

from ..core.body import pelvis_joint
from ..core.motion import Motion
from ..core.rotations import (
    quat_angle,
    quat_between_vectors,
    quat_conj,
    quat_mul,
    quat_rotate,
    quat_to_rotvec,
    rotvec_to_quat,
    slerp,
)
from .limbs import _fk_joints
from .plants_air import _leaf_effectors_as_edited, _legs_in_air, _toe_up  # noqa: F401  (_toe_up: tests)
from .plants_carry import _source_frames
from .plants_ik import (
    _capped,
    _no_hyperextension,
    _pivot,
    _solve,
    _unit,
)
from .plants_pops import POP_MARGIN, cap_pops
from .plants_rate import KNEE_MARGIN, _knee_lag, knee_rate_reach, pivot_rate
from .plants_root import _MAX_SIDE, _TOL, _below, _choose_shifts, _reach, _root_shift, _vertical_need
from .plants_sample import _length, _raised_cosine, _sample, _sample_quats, _sample_rows, _scaled_along
from .plants_source import _SOURCE_CACHE, _source_steps, _source_tables  # noqa: F401  (_SOURCE_CACHE: plants)

_ID = np.array([0.0, 0.0, 0.0, 1.0])
_MAX_AIM = np.radians(30.0)     # the most the foot turns about its ankle to put the toe on its own plant
_MAX_PIVOT = np.radians(45.0)   # the most the foot turns about its toe (heel lift) beyond the source's
_SOFT = 0.05         # share of a leg over which a fading target's reach limit is approached smoothly
_SOFT_DROP = 0.028   # share of a leg: the root is lowered beyond this (up to max_drop) only where with it ...
_SHORT = 0.005       # ... a held leg would stop more than this share of a leg (~0.45 cm) short of its plant
_FADE_RATE = 90.0     # degrees per second: the most a fade out of (into) a plant turns a joint on top of the edit


def _hold(motion: Motion, source: Motion, limbs: dict, plants: list, carried: list, timeline, blend: float,
          share: float, max_drop: float, reach: float, targets=None, shift_plants: bool = True,
          above_floor: bool = True, cap: bool = True, clock=None):
    """The layer on the evaluated ``motion``: ``(held motion, root drop (F,), notes)``; ``clock``: the time-warp
    column that carried each contact joint and effector (:func:`~.plants_carry.carry_clocks`; default its own),
    whose inverse warp gives its source times inside the plant."""
    clock = {} if clock is None else clock
    sk = motion.skeleton
    F = motion.num_frames
    ft, ft_s = motion.frame_time, source.frame_time
    t0, tables = timeline[0], timeline[3]
    nb = int(round(blend / ft))
    nc = max(1, nb)                                         # fade of one contact's correction inside a plant
    legs = [lim for lim in limbs.values() if lim.leg]
    joints = set()
    for lim in limbs.values():
        joints |= {lim.upper, lim.mid, lim.eff, int(sk.parents[lim.mid]), int(sk.parents[lim.eff])}
    pos, wq = _fk_joints(motion, joints)
    spos, swq, src_share, hinges, floor, backs = _source_tables(source, limbs)
    slq = source.local_quats
    length = {e: _length(pos, lim) for e, lim in limbs.items()}              # (F,) per limb
    med = {e: float(np.median(length[e])) for e in limbs}
    steps, ratio = _source_steps(source), ft / ft_s
    if not plants:
        # no plant (no contact, or none carried onto a frame): only the legs kept above the source's floor
        out = np.array(motion.local_quats)
        _legs_in_air(sk, motion, legs, [], {}, np.zeros((F, 3)), out, floor, nb, med, length, hinges, above_floor,
                     backs)
        _leaf_effectors_as_edited(limbs, out, motion.local_quats)
        if cap:
            _cap(sk, limbs, [], out, motion.local_quats, source, ft / ft_s)
        if np.array_equal(out, motion.local_quats):
            return motion, np.zeros(F), []
        return Motion._trusted(sk, ft, motion.root_positions, out, motion.local_translations), np.zeros(F), []
    # -- each plant's frames: the source time sigma (the inverse warp of the clock that carries the effector,
    # kept inside the plant's source frames) and the source foot there ---------------------------------------
    P = len(plants)
    sizes = np.array([p["stop"] - p["start"] for p in plants])
    in_fr = np.concatenate([np.arange(p["start"], p["stop"]) for p in plants])
    in_pid = np.repeat(np.arange(P), sizes)
    effs = np.array([p["eff"] for p in plants])
    e_of, u_of = effs[in_pid], np.array([limbs[e].upper for e in effs])[in_pid]
    in_sig = np.empty(in_fr.size)
    for e in limbs:
        sel = e_of == e
        in_sig[sel] = _source_frames(tables, t0, ft, ft_s, clock.get(e, e), in_fr[sel])
    s_lo, s_hi = np.array([p["s_lo"] for p in plants]), np.array([p["s_hi"] for p in plants])
    in_sig = np.clip(in_sig, s_lo[in_pid], s_hi[in_pid])
    base = _sample_rows(spos, in_sig, e_of)                                  # (n, 3) source foot at sigma
    hip, cur = pos[in_fr, u_of], pos[in_fr, e_of]
    L_in = np.concatenate([length[p["eff"]][p["start"]:p["stop"]] for p in plants])
    s_in = np.empty(in_fr.size)
    for e in limbs:
        sel = e_of == e
        s_in[sel] = _sample(src_share[e], in_sig[sel])
    R_in = _reach(reach, L_in, np.linalg.norm(cur - hip, axis=-1), s_in)
    # where the edited foot sits at the plant's first frame, against the source foot there: the plant is held
    # there (horizontally; _choose_shifts), so the hip reaches it as the edit placed the leg (Kovar et al. 2002,
    # §4: the plant's position from the motion being cleaned)
    d0 = (cur - base)[np.r_[0, np.cumsum(sizes)[:-1]]]
    lengths = np.array([med[e] for e in effs])
    p_start, p_stop = np.array([p["start"] for p in plants]), np.array([p["stop"] for p in plants])
    shift = _choose_shifts(hip, base, R_in, in_pid, d0, lengths) if shift_plants else np.zeros((P, 3))
    contacts_of: dict[int, list] = {}
    for c in carried:
        contacts_of.setdefault(c[7], []).append(c)
    rows = []
    need = np.zeros(F)
    f_all = np.arange(F)
    for eff, lim in limbs.items():
        sel = np.flatnonzero(e_of == eff)
        if not sel.size:
            continue
        fr, sig, pid = in_fr[sel], in_sig[sel], in_pid[sel]
        d = shift[pid]
        # the plant's own frames: the source foot at sigma, shifted, each contact joint then put where the
        # source has it at that joint's own time (w_j^-1), faded (C1) over nc frames inside the plant
        p_ref = _sample(spos[:, eff], sig) + d
        q_ref = _sample_quats(swq[:, eff], sig)
        n = fr.size
        da, wa = np.zeros((n, 3)), np.zeros(n)
        dt_sum, pt_sum, wt_sum, wt = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n)
        lo, hi = p_start[pid], p_stop[pid]
        at_sig = {}
        mine = contacts_of.get(eff, ())
        ks = np.searchsorted(fr, [x for c in mine for x in (c[3], c[4])]).reshape(-1, 2)
        # each contact joint's source times (its carrying clock's), one inverse warp per joint over its contacts' frames
        own_t = {}
        for j in {c[0] for c in mine}:
            idx = [i for i, c in enumerate(mine) if c[0] == j and ks[i, 1] > ks[i, 0]
                   and (targets is None or targets[c[8]] is None)]
            if idx:
                t_all = _source_frames(tables, t0, ft, ft_s, clock.get(j, j),
                                       np.concatenate([fr[ks[i, 0]:ks[i, 1]] for i in idx]))
                cut = np.cumsum([ks[i, 1] - ks[i, 0] for i in idx])[:-1]
                own_t.update(zip(idx, np.split(t_all, cut)))
        for i, (j, _e0, _e1, A, B, a, b, _, ci) in enumerate(mine):
            kA, kB = ks[i]
            if kB <= kA:
                continue
            own = fr[kA:kB]
            if j not in at_sig:
                at_sig[j] = _sample(spos[:, j], sig)
            if targets is not None and targets[ci] is not None:     # given: where the joint must be
                delta = np.broadcast_to(targets[ci], (B - A, 3)) - at_sig[j][kA:kB] - d[kA:kB]
            else:
                ts = np.clip(own_t[i], a, b - 1)
                delta = _sample(spos[:, j], ts) - at_sig[j][kA:kB]
            k0, k1 = np.searchsorted(fr, [A - nc, B + nc])
            seg = np.arange(k0, k1)
            seg = seg[(lo[seg] <= A) & (hi[seg] >= B)]         # this contact's plant only
            f_seg = fr[seg]
            dist = np.where(f_seg < A, A - f_seg, np.where(f_seg >= B, f_seg - (B - 1), 0))
            om = _raised_cosine(dist, nc)
            dseg = delta[np.clip(np.searchsorted(own, f_seg), 0, own.size - 1)]
            if j == eff:
                take = om > wa[seg]
                wa[seg] = np.where(take, om, wa[seg])
                da[seg] = np.where(take[:, None], dseg, da[seg])
            else:
                dt_sum[seg] += om[:, None] * dseg
                pt_sum[seg] += om[:, None] * (at_sig[j][seg] + d[seg])
                wt_sum[seg] += om
                wt[seg] = np.maximum(wt[seg], om)
        has_t = wt_sum > 0
        dt = np.where(has_t[:, None], dt_sum / np.where(has_t, wt_sum, 1.0)[:, None], 0.0)
        pt = np.where(has_t[:, None], pt_sum / np.where(has_t, wt_sum, 1.0)[:, None], p_ref)
        ankle = p_ref + wa[:, None] * da + ((1 - wa) * wt)[:, None] * dt
        both = (wa * wt) > 0
        if both.any():
            # heel and toe held at once, each at its carried source time: the toe aimed at its plant by turning
            # the foot about the ankle, and what the rigid foot's length cannot fit shared by the two
            toe_t = pt[both] + dt[both]
            v = toe_t - ankle[both]
            foot = np.linalg.norm(pt[both] - p_ref[both], axis=-1)
            gap = (np.linalg.norm(v, axis=-1) - foot) * 0.5 * (wa * wt)[both]
            ankle[both] += gap[:, None] * _unit(v)
            turn = _capped(quat_between_vectors(pt[both] - p_ref[both], toe_t - ankle[both]), _MAX_AIM)
            q_ref[both] = quat_mul(slerp(np.broadcast_to(_ID, turn.shape), turn, (wa * wt)[both]), q_ref[both])
        e_cur = pos[fr, eff]
        h = pos[fr, lim.upper]
        R = _reach(reach, length[eff][fr], np.linalg.norm(e_cur - h, axis=-1), _sample(src_share[eff], sig))
        toe_only = (wt * (1 - wa)) > 0
        if toe_only.any():
            # only the toe held (heel-off): where the leg cannot reach the ankle, the foot turns further about
            # the toe towards the hip (the heel lifts more), by the least angle that brings the ankle in reach
            k = np.flatnonzero(toe_only)
            toe_t = pt[k] + dt[k]
            off = ankle[k] - toe_t
            turn = _capped(quat_between_vectors(off, _pivot(off, h[k] - toe_t, R[k])), _MAX_PIVOT)
            if cap:         # the lift adds no more turn a frame than the pop cap's margin (plants_rate)
                turn = rotvec_to_quat(pivot_rate(off, h[k] - toe_t, quat_angle(turn), _MAX_PIVOT, fr[k], pid[k],
                                                 np.radians(POP_MARGIN)))
            turn = slerp(np.broadcast_to(_ID, turn.shape), turn, (wt * (1 - wa))[k])
            ankle[k] = toe_t + quat_rotate(turn, off)
            q_ref[k] = quat_mul(turn, q_ref[k])
        if lim.leg and cap:
            # the knee bends no faster inside a plant than the source's fastest knee turn plus KNEE_MARGIN (half
            # the pop cap's margin): the reach lowered where the plant asks for more (plants_rate), so the root
            # comes down that little instead of the cap freeing the plant's frames
            l1 = np.linalg.norm(pos[fr, lim.mid] - h, axis=-1)
            l2 = np.linalg.norm(e_cur - pos[fr, lim.mid], axis=-1)
            rate = float(steps[lim.mid]) * ratio + np.radians(KNEE_MARGIN)
            R = knee_rate_reach(h, ankle, l1, l2, R, fr, pid, rate)
        np.maximum.at(need, fr, _vertical_need(h, ankle, R) - _TOL * length[eff][fr])
        foot_q = [_sample_quats(slq[:, k], sig) for k in lim.foot]
        rows.append(dict(lim=lim, fr=fr, g=ankle, R=R, q=q_ref, foot=foot_q, sig=sig, pid=pid))
    notes = []
    shift = np.zeros((F, 3))
    if share > 0 and max_drop > 0 and np.any(need > 0):
        leg = float(min(lengths))

        def lowered_by(cap):
            sh = _root_shift(F, rows, pos, cap * leg, _MAX_SIDE * leg, nb) * share
            lf = np.zeros(F)
            for r in rows:
                h = pos[r["fr"], r["lim"].upper] + sh[r["fr"]]
                np.maximum.at(lf, r["fr"], np.linalg.norm(r["g"] - h, axis=-1) - r["R"])
            return sh, lf

        # the pelvis goes below the small budget only where the feet would otherwise stop visibly short
        shift, left = lowered_by(min(max_drop, _SOFT_DROP))
        if max_drop > _SOFT_DROP and left.max() > _SHORT * leg:
            shift, left = lowered_by(max_drop)
        short = int(np.sum(left > 1e-3 * leg))
        if short:
            notes.append(f"keep_contacts: on {short} frame{'s' if short > 1 else ''} a held leg cannot reach its "
                         f"plant with the pelvis at most {100 * max_drop * share:.1f} % of a leg lower and "
                         f"{100 * _MAX_SIDE * share:.0f} % of a leg aside: the foot stops short of the plant there")
    drop = np.maximum(-shift[:, 1], 0.0)
    rp = motion.root_positions
    lowered = pos
    lt = motion.local_translations
    if np.any(shift != 0):
        lowered = pos + shift[:, None, :]
        pel = pelvis_joint(sk)
        par = int(sk.parents[pel])
        if pel == 0 or par < 0 or not all(_below(sk, lim.upper, pel) for lim in limbs.values()):
            rp = np.array(rp) + shift
        else:
            # a static root joint below the pelvis (Bandai's joint_Root on the floor): the pelvis moves, not it
            lt = np.array(np.broadcast_to(sk.offsets, (F,) + sk.offsets.shape) if lt is None else lt)
            lt[:, pel] += quat_rotate(quat_conj(wq[:, par]), shift)
    lq = motion.local_quats
    out = np.array(lq)
    # the plants' own frames: exact IK
    for r in rows:
        lim, fr = r["lim"], r["fr"]
        a_new, m_new, e_new = _solve(sk, lim, fr, lowered, wq, lq, r["g"], r["q"], r["R"], hinges[lim.eff],
                                      max_back=backs[lim.eff], groups=r["pid"])
        out[fr, lim.upper], out[fr, lim.mid], out[fr, lim.eff] = a_new, m_new, e_new
        for k, fq in zip(lim.foot, r["foot"]):
            out[fr, k] = fq
    # around them: the boundary solution's displacement (each joint's rotation against the edit's), faded
    # out with a C1 raised cosine (Coleman et al. §3) over a window long enough that the fade turns no joint
    # faster than _FADE_RATE on top of the edit; between two plants the two displacements are interpolated
    fade_w = {}
    for r in rows:
        lim, fr = r["lim"], r["fr"]
        inside = np.zeros(F, bool)
        inside[fr] = True
        starts = np.flatnonzero(inside & ~np.r_[False, inside[:-1]])
        ends = np.flatnonzero(inside & ~np.r_[inside[1:], False])
        bnd = np.r_[starts, ends]
        ch = np.array([lim.upper, lim.mid, lim.eff] + list(lim.foot))
        disp = quat_mul(quat_conj(lq[bnd][:, ch]), out[bnd][:, ch])                    # (boundaries, C, 4)
        # ... and its rate there (per frame, towards the outside: from the plant's second frame to its first,
        # from its second-last to its last), carried on, damped, so the fade starts with the plant's slope (C1)
        inner = np.r_[np.minimum(starts + 1, F - 1), np.maximum(ends - 1, 0)]
        inner = np.where(inside[inner], inner, bnd)
        rate = quat_to_rotvec(quat_mul(quat_conj(quat_mul(quat_conj(lq[inner][:, ch]), out[inner][:, ch])), disp))
        size = quat_angle(disp)                                                         # (boundaries, C) radians
        angle = size.max(axis=1)
        width = np.clip(np.ceil(angle * np.pi / (2 * np.radians(_FADE_RATE) * ft)) - 1, nb, 4 * nb).astype(np.int64)
        w_start, w_end = width[:starts.size], width[starts.size:]
        li = np.searchsorted(ends, f_all, side="right") - 1
        ri = np.searchsorted(starts, f_all, side="right")
        li_, ri_ = np.maximum(li, 0), np.minimum(ri, starts.size - 1)
        has_l, has_r = (li >= 0) & ~inside, (ri < starts.size) & ~inside
        dl = np.where(has_l, f_all - ends[li_], 0)
        dr = np.where(has_r, starts[ri_] - f_all, 0)
        # how far a leg's take-off into the air (no plant ahead of it) is replayed: on the knee's own clock
        # where the edit slowed the knee against the hip (_knee_lag), else frame for frame (below)
        x_l = dl * np.where(has_r, 1.0, _knee_lag(tables, t0, ft, ft_s, lim, ends, nb, F)[li_]) if lim.leg else dl
        wl = np.where(has_l, _raised_cosine(dl, w_end[li_]), 0.0)
        wr = np.where(has_r, _raised_cosine(dr, w_start[ri_]), 0.0)
        win = np.flatnonzero((wl > 0) | (wr > 0))
        if not win.size:
            continue
        wl_, wr_ = wl[win], wr[win]
        # the right plant's share: its weight over its distance against the left's (1 next to the right plant,
        # 0 next to the left one, and continuous where either fade begins)
        ql, qr = wl_ / np.maximum(dl[win], 1), wr_ / np.maximum(dr[win], 1)
        al = qr / (ql + qr)
        w = wl_ + wr_ - wl_ * wr_
        kl, kr = starts.size + li_[win], ri_[win]
        fade_w[lim.eff] = (win, w)
        tau_l = np.maximum(w_end[li_[win]], 1) / 3.0
        tau_r = np.maximum(w_start[ri_[win]], 1) / 3.0
        s_l = (tau_l * -np.expm1(-dl[win] / tau_l))[:, None]          # ~ frames out, levelling off
        s_r = (tau_r * -np.expm1(-dr[win] / tau_r))[:, None]
        # the carried-on rate turns the displacement by at most its own size, and never past 0.9 pi (a turn
        # beyond half a revolution would flip to the other way round)
        size = np.minimum(size, np.maximum(0.9 * np.pi - size, 0.0))
        r_l, r_r = rate[kl], rate[kr]                                                   # (n, C, 3)
        if lim.leg:
            # a leg's fade is solved in world space below: this joint-space fade is only its reference pose (the
            # knee's plane), without the carried-on rate, which can swing a straight leg far off its target (run,
            # s = +0.1: a 130-degree aim, the hip then flipping 140-180 degrees a frame)
            r_l, r_r = np.zeros_like(r_l), np.zeros_like(r_r)
        r_l = r_l * np.minimum(1.0, size[kl] / np.maximum(np.linalg.norm(r_l, axis=-1) * tau_l[:, None],
                                                          1e-300))[..., None]
        r_r = r_r * np.minimum(1.0, size[kr] / np.maximum(np.linalg.norm(r_r, axis=-1) * tau_r[:, None],
                                                          1e-300))[..., None]
        d_l = quat_mul(disp[kl], rotvec_to_quat(r_l * s_l[..., None]))
        d_r = quat_mul(disp[kr], rotvec_to_quat(r_r * s_r[..., None]))
        shape = d_l.shape[:-1]
        dd = slerp(d_l, d_r, np.broadcast_to(al[:, None], shape))
        dd = _scaled_along(dd, w, win)
        out[win[:, None], ch[None, :]] = quat_mul(lq[win][:, ch], dd)
        _no_hyperextension(sk, motion, lim, win, out, lq, pos, wq, hinges[lim.eff])
        if lim.leg:
            # the fade's foot in world space (Kovar et al. 2002, §4: the constrained and the unconstrained
            # positions blended): from where the edit puts the ankle to the plant's boundary target (between two
            # plants: the two targets, by the right plant's share), and the foot's world orientation likewise;
            # the legs-in-the-air step below solves the leg for it
            # each boundary's target carried on outside the plant as the source's own approach / take-off:
            # the source foot at sigma extended with slope 1, with the boundary's offset from it (an unedited
            # motion: its own foot)
            gi = np.searchsorted(fr, bnd)
            sig_b = r["sig"][gi]
            off_p = r["g"][gi] - _sample(spos[:, lim.eff], sig_b)
            off_q = quat_mul(quat_conj(_sample_quats(swq[:, lim.eff], sig_b)), r["q"][gi])
            ext = []
            # (a take-off into the air on the knee's clock, x_l: frame for frame, a knee whose clock the edit
            # slowed against the hip's bent through the source's whole take-off within a few of its own frames,
            # which read as jitter on its own timing: xia_neutral_walk at s = -0.1, detail of the knee x8.8)
            for k, off in ((kl, x_l[win]), (kr, -dr[win])):
                sg = sig_b[k] + off * ratio
                ext.append((_sample(spos[:, lim.eff], sg) + off_p[k],
                            quat_mul(_sample_quats(swq[:, lim.eff], sg), off_q[k]), _sample(src_share[lim.eff], sg)))
            g_mix = ext[0][0] * (1 - al)[:, None] + ext[1][0] * al[:, None]
            q_mix = slerp(ext[0][1], ext[1][1], al)
            target = pos[win, lim.eff] * (1 - w)[:, None] + g_mix * w[:, None]
            # the fade's leg may reach as far as a plant's may (_reach: the edit's own extension, the source's
            # there, else ``reach`` of the leg), not to full extension: a fade into a plant the leg cannot
            # reach straightened the knee, which the plant's first frame then bent back by 18 degrees at once
            # (cmu_01_01 from mid-swing, mild; the pop cap then let the foot off its plant by 3 cm)
            r_f = _reach(reach, length[lim.eff][win], np.linalg.norm(pos[win, lim.eff] - pos[win, lim.upper], axis=-1),
                         ext[0][2] * (1 - al) + ext[1][2] * al)
            fade_w[lim.eff] = (win, w, target, q_mix, r_f)
    _legs_in_air(sk, motion, legs, rows, fade_w, shift, out, floor, nb, med, length, hinges, above_floor,
                 backs)
    _leaf_effectors_as_edited(limbs, out, lq)
    if cap:
        _cap(sk, limbs, rows, out, lq, source, ft / ft_s)
    return Motion._trusted(sk, motion.frame_time, rp, out, lt), drop, notes





def _cap(sk, limbs: dict, rows: list, out: np.ndarray, lq: np.ndarray, source: Motion, ratio: float) -> None:
    """No corrected joint of ``limbs`` turns faster on top of the edit ``lq (F, J, 4)`` than the pop cap allows
    (in place on ``out``; :mod:`.plants_pops`), the plants' own frames (``rows``) kept exactly; ``ratio``: the
    edited frame time over the source's."""
    F = out.shape[0]
    # no joint turns faster on top of the edit than the pop cap allows (plants_pops)
    chains = [x for lim in limbs.values() for x in (lim.upper, lim.mid, lim.eff) + lim.foot]
    pinned = np.zeros((F, sk.num_joints), bool)       # the plants' own frames are kept exactly
    for r in rows:
        lim = r["lim"]
        for x in (lim.upper, lim.mid, lim.eff) + lim.foot:
            pinned[r["fr"], x] = True
    cap_pops(out, lq, chains, _source_steps(source) * ratio, pinned)
