"""The contact plant's step written once for both array backends (`ContactPlant.xp`):
Python floats for one episode, numpy arrays of shape (n,) for a batch.

This is the plant's model as `robot_sim.contact.plant` describes it (gripper frame: x toward
the receiver, y down; m, m/s, N, s). A batch steps with it; a one-episode plant steps with
`robot_sim.contact.scalar_step.run_steps`, the same operations inline on floats, checked
against this one bit for bit (`tests/unit/contact/test_fast_stepping.py`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from handover_model.grip import Mode

if TYPE_CHECKING:
    from robot_sim.contact.plant import ContactPlant

__all__ = ["step_generic"]

_TINY = 1e-12
_GRASP, _SLIP, _RELEASE = int(Mode.GRASP), int(Mode.SLIP), int(Mode.RELEASE)


def step_generic(p: ContactPlant, grip_command_n) -> None:
    """Advance `p` by one plant step of `p.dt_s` (s) with the grip-force command (N)."""
    xp = p.xp
    where, maximum, hypot = xp.where, xp.maximum, xp.hypot
    (dt, m, w, mu_s, mu_k, kc, cc, kh, dh, mh, ext_x, ext_y, face_x, face_y,
     max_gap, drop_m, hold_level, k_spring) = p._constants
    k = p.step_index
    act = p.actuator
    if k % p._gripper_every == 0:
        p._latch(grip_command_n)
    rx, ry, rvx, rvy, g, ffy = p._reference_at(k)
    px, py, vx, vy = p.px, p.py, p.vx, p.vy
    hx, hy, hvx, hvy = p.hx, p.hy, p.hvx, p.hvy
    # 1. Hand on object.
    dx, dy = hx - px, hy - py
    dvx, dvy = hvx - vx, hvy - vy
    fx = g * (kc * dx + cc * dvx)
    fy = g * (kc * dy + cc * dvy)
    ux, uy = p._ux, p._uy
    c_full, c_along = p._c_full, p._c_along
    along = fx * ux + fy * uy
    pen = dx * ux + dy * uy
    push = where(pen > 0.0, maximum(kc * pen + cc * (dvx * ux + dvy * uy), 0.0), 0.0)
    fx = where(c_full, fx, where(c_along, along * ux, push * ux))
    fy = where(c_full, fy, where(c_along, along * uy, push * uy))
    cap = where(p._c_contact, p._strength, g * p._strength)
    mag = hypot(fx, fy)
    sc = where(mag > cap, cap / maximum(mag, _TINY), 1.0)
    fx, fy = fx * sc, fy * sc
    # 2.-3. Pads: Coulomb friction with stick/slip.
    finger = act.finger_m
    fg_spring = k_spring * maximum(finger, 0.0)
    left = p.left
    in_pads = xp.not_(left) & (fg_spring > 0.0)
    fg = where(in_pads, fg_spring, 0.0)
    ex, ey = fx, fy + w
    ptx, pty = m * vx + dt * ex, m * vy + dt * ey
    pt = hypot(ptx, pty)
    jk = dt * mu_k * fg
    can_hold = in_pads & (hypot(ex, ey) <= mu_s * fg)
    stay = p.stuck & can_hold
    stops = pt <= jk
    stuck = stay | (stops & can_hold)
    keep = where(stay | stops, 0.0, 1.0 - jk / maximum(pt, _TINY))
    nvx, nvy = ptx * keep / m, pty * keep / m
    p.wrist_x = (ptx - m * nvx) / dt
    p.wrist_y = (pty - m * nvy) / dt
    p.ax, p.ay = (nvx - vx) / dt, (nvy - vy) / dt
    npx, npy = px + dt * nvx, py + dt * nvy
    p.mode = where(in_pads, where(stuck, _GRASP, _SLIP), _RELEASE)
    p.grip_force_n = fg
    p.stuck = stuck
    abs_ = xp.abs
    apx, apy = abs_(npx), abs_(npy)
    left = left | (apx > ext_x) | (apy > ext_y)
    p.left = left
    # Hand impedance (reaction of the object on the hand included).
    hvx = hvx + dt * (kh * (rx - hx) + dh * (rvx - hvx) - fx) / mh
    hvy = hvy + dt * (kh * (ry - hy) + dh * (rvy - hvy) + ffy - fy) / mh
    p.hx, p.hy = hx + dt * hvx, hy + dt * hvy
    p.hvx, p.hvy = hvx, hvy
    p.pull_x, p.pull_y = fx, fy
    p.grasp = g
    holds = c_full & (g >= hold_level) & (hypot(dx, dy) < 0.02)
    p.holds = holds
    p.dropped = p.dropped | ((npy > drop_m) & xp.not_(holds))
    # Sensors.
    visible = xp.not_(left) & (apx <= face_x) & (apy <= face_y) & (maximum(-finger, 0.0) <= max_gap)
    p.optical.accumulate(npx - px, npy - py, hypot(nvx, nvy), visible)
    p.px, p.py, p.vx, p.vy = npx, npy, nvx, nvy
    act.move()
    k += 1
    p.step_index = k
    if k % p._ft_every == 0:
        p.ft.sample(p.wrist_x, p.wrist_y)
        p.ft_fresh = True
    if k % p._opt_every == 0:
        p.optical.report(visible)
        p.optical_fresh = True
