"""The contact plant's step for one episode on Python floats, state in local variables.

`run_steps(plant, grip_command_n, n)` runs `n` plant steps of `ContactPlant` exactly as the
backend-generic step (`robot_sim.contact.generic_step.step_generic`) does on floats: the same
floating-point operations on the same values in the same order, so every state variable,
sensor reading and noise draw comes out bit for bit the same. What is gone is only Python
overhead: the state is read into local variables once per call and written back once, the
backend's `where`/`maximum`/`clip` calls are inline conditionals with the same results
(``max(x, 0.0)`` is ``0.0 if x < 0.0 else x``: it keeps −0.0 and NaN as the built-in does),
and the values only the last step leaves behind (acceleration, mode) are computed once.
`tests/unit/contact/test_fast_stepping.py` checks it against the generic step.

Frames and units as in `robot_sim.contact.plant`: gripper frame, x toward the receiver, y
down; m, m/s, N, s.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from robot_sim.contact.actuator import DEAD_BAND_M
from handover_model.grip import Mode

if TYPE_CHECKING:
    from robot_sim.contact.plant import ContactPlant

__all__ = ["run_steps"]

_TINY = 1e-12
_GRASP, _SLIP, _RELEASE = int(Mode.GRASP), int(Mode.SLIP), int(Mode.RELEASE)


def _partial_coupling(fx, fy, dx, dy, dvx, dvy, ux, uy, kc, cc, along_pull):
    """The hand's force (N) when the grasp transmits only the part along the pull u = (ux, uy)
    (`along_pull`, dropping) or only a one-sided push along u (bumping)."""
    if along_pull:
        along = fx * ux + fy * uy
        return along * ux, along * uy
    pen = dx * ux + dy * uy
    if pen > 0.0:
        push = kc * pen + cc * (dvx * ux + dvy * uy)
        if push < 0.0:
            push = 0.0
    else:
        push = 0.0
    return push * ux, push * uy


def run_steps(p: ContactPlant, grip_command_n: float, n: int) -> None:
    """Run `n` plant steps of `p.dt_s` (s) with the grip command `grip_command_n` (N) on a
    single-episode (float) plant."""
    if n < 1:
        return
    (dt, m, w, mu_s, mu_k, kc, cc, kh, dh, mh, ext_x, ext_y, face_x, face_y,
     max_gap, drop_m, hold_level, k_spring) = p._constants
    act, opt, ft, hypot = p.actuator, p.optical, p.ft, math.hypot
    ux, uy, c_full, c_along, strength = p._ux, p._uy, p._c_full, p._c_along, p._strength
    cap_fixed = strength if p._c_contact else None
    alpha, max_step, max_speed = act._alpha, act._max_step_m, opt._max_speed
    grip_every, ft_every, opt_every = p._gripper_every, p._ft_every, p._opt_every
    k, cache, base, acc_x, acc_y = p.step_index, p._ref_cache, p._ref_base, opt._acc_x, opt._acc_y
    settled_k, settled = p._ref_settled or (-1, ())
    px, py, vx, vy, hx, hy, hvx, hvy = p.px, p.py, p.vx, p.vy, p.hx, p.hy, p.hvx, p.hvy
    stuck, left, dropped, finger, target = p.stuck, p.left, p.dropped, act.finger_m, act.target_m
    for _ in range(n):
        if k % grip_every == 0:
            p._latch(grip_command_n)
            target = act.target_m
        if 0 <= k - base < len(cache):
            rx, ry, rvx, rvy, g, ffy = cache[k - base]
        elif 0 <= settled_k <= k:
            rx, ry, rvx, rvy, g, ffy = settled
        else:
            rx, ry, rvx, rvy, g, ffy = p._reference_at(k)
            cache, base = p._ref_cache, p._ref_base
            settled_k, settled = p._ref_settled or (-1, ())
        # 1. Hand on object.
        dx, dy, dvx, dvy = hx - px, hy - py, hvx - vx, hvy - vy
        fx, fy = g * (kc * dx + cc * dvx), g * (kc * dy + cc * dvy)
        if not c_full:
            fx, fy = _partial_coupling(fx, fy, dx, dy, dvx, dvy, ux, uy, kc, cc, c_along)
        cap = g * strength if cap_fixed is None else cap_fixed
        mag = hypot(fx, fy)
        sc = cap / (_TINY if mag < _TINY else mag) if mag > cap else 1.0
        fx, fy = fx * sc, fy * sc
        # 2.-3. Pads: Coulomb friction with stick/slip.
        fg = k_spring * (0.0 if finger < 0.0 else finger)
        in_pads = not left and fg > 0.0
        fg, ey = fg if in_pads else 0.0, fy + w
        ptx, pty = m * vx + dt * fx, m * vy + dt * ey
        pt, jk = hypot(ptx, pty), dt * mu_k * fg
        can_hold = in_pads and hypot(fx, ey) <= mu_s * fg
        stay, stops = stuck and can_hold, pt <= jk
        stuck = stay or (stops and can_hold)
        keep = 0.0 if stay or stops else 1.0 - jk / (_TINY if pt < _TINY else pt)
        nvx, nvy = ptx * keep / m, pty * keep / m
        wrist_x, wrist_y = (ptx - m * nvx) / dt, (pty - m * nvy) / dt
        npx, npy = px + dt * nvx, py + dt * nvy
        apx, apy = abs(npx), abs(npy)
        left = left or apx > ext_x or apy > ext_y
        # Hand impedance (reaction of the object on the hand included).
        hvx = hvx + dt * (kh * (rx - hx) + dh * (rvx - hvx) - fx) / mh
        hvy = hvy + dt * (kh * (ry - hy) + dh * (rvy - hvy) + ffy - fy) / mh
        hx, hy = hx + dt * hvx, hy + dt * hvy
        holds = c_full and g >= hold_level and hypot(dx, dy) < 0.02
        dropped = dropped or (npy > drop_m and not holds)
        # Sensors, then the finger's motion.
        visible = not left and apx <= face_x and apy <= face_y and (0.0 if -finger < 0.0 else -finger) <= max_gap
        ok = visible and hypot(nvx, nvy) <= max_speed
        acc_x, acc_y = acc_x + (npx - px if ok else 0.0), acc_y + (npy - py if ok else 0.0)
        last_vx, last_vy, px, py, vx, vy = vx, vy, npx, npy, nvx, nvy
        err = target - finger
        move = err * alpha
        move = -max_step if move < -max_step else (max_step if move > max_step else move)
        finger = target if abs(err) <= DEAD_BAND_M else finger + move
        k += 1
        if k % ft_every == 0:
            ft.sample(wrist_x, wrist_y)
            p.ft_fresh = True
        if k % opt_every == 0:
            opt._acc_x, opt._acc_y = acc_x, acc_y
            opt.report(visible)
            acc_x, acc_y, p.optical_fresh = opt._acc_x, opt._acc_y, True
    p.px, p.py, p.vx, p.vy, p.hx, p.hy, p.hvx, p.hvy = px, py, vx, vy, hx, hy, hvx, hvy
    p.ax, p.ay, p.mode = (vx - last_vx) / dt, (vy - last_vy) / dt, (_GRASP if stuck else _SLIP) if in_pads else _RELEASE
    p.grip_force_n, p.stuck, p.left, p.dropped, p.grasp, p.holds = fg, stuck, left, dropped, g, holds
    p.pull_x, p.pull_y, p.wrist_x, p.wrist_y = fx, fy, wrist_x, wrist_y
    act.finger_m, opt._acc_x, opt._acc_y, p.step_index = finger, acc_x, acc_y, k
