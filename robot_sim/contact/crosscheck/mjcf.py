"""The pinch in MuJoCo: two force-driven pads squeeze a box; the independent plant against
which `robot_sim.contact.plant` is checked.

Model (MJCF built in code, no assets):

- **box**: mass M, half-extents (e_x/2, w/2, e_y/2), where e_x, e_y are our plant's pad
  extents (`ObjectParams.pad_extent_x_m`, `pad_extent_y_m`) and w the box width across the
  grip. It moves on three slide joints (x, the grip axis, z): our plant models no rotation,
  so by default neither does this box (`MujocoParams.free_rotation` gives it a free joint).
- **pads**: two boxes of the same face (e_x/2 × e_y/2 half-extents), one each side, each on a
  slide joint along the grip axis driven by a force actuator (`motor`): the grip force F_G
  is the pads' normal force, applied directly. The face overlap of box and pad ends once the
  box has moved more than e_x along x or e_y along z: the same pad extent as our plant's,
  here by geometry.
- **contacts**: only the two pad–box pairs, `condim=3` with an **elliptic** friction cone
  (`cone="elliptic"`), friction coefficient μ/2 per pad (our μ is the total of both pads,
  thesis: "μ_s is twice the coefficient of one finger"). MuJoCo has one friction coefficient,
  no separate static and kinetic ones. Soft contacts: `solref` (time constant, damping ratio)
  and `solimp` (d0, dwidth, width, midpoint, power) as in `MujocoParams`; `impratio` makes
  the friction dimensions stiffer than the normal one and so reduces the creep a soft
  friction constraint allows under a static load (measured in the docs and `diagnostics`).
- **hand**: a point mass (`HandParams.mass_kg`) on two slide joints (x, z), weightless
  (`gravcomp`); the crosscheck applies its impedance and grasp forces (`runs`).

Frames: MuJoCo's world has x toward the receiver (our x), y along the grip axis and z up.
Our gripper frame has y DOWN. Every position, velocity and force `MujocoPinch` takes or
returns is in OUR gripper frame (x toward the receiver, y down; m, m/s, N), converted here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_sim.contact.config import ContactSimError, ObjectParams

__all__ = ["MujocoParams", "MujocoPinch", "pinch_mjcf", "MUJOCO_DEFAULT_SOLIMP"]

#: MuJoCo's own default solimp (d0, d_width, width m, midpoint, power), for comparison.
MUJOCO_DEFAULT_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)


@dataclass(frozen=True)
class MujocoParams:
    """MuJoCo's numerical and geometric choices (SI units). The values were chosen by the
    measurements in the docs ("Independent cross-check (MuJoCo)"; `diagnostics`).

    timestep_s: MuJoCo step (our plant's dt, 1 ms). integrator: MuJoCo's semi-implicit Euler.
    impratio: friction-to-normal impedance ratio of the elliptic cone. MuJoCo's default 1
        lets a stuck box near the cone creep at ~17 mm/s; 200 keeps it below 0.1 mm/s.
    solref_timeconst_s, solref_dampratio: contact time constant and damping ratio (MuJoCo's
        default 0.02 s, 1; here 4 ms: ≥ 2 time steps as MuJoCo asks).
    solimp: impedance (d0, d_width, width m, midpoint, power). MuJoCo's default
        (`MUJOCO_DEFAULT_SOLIMP`) makes a sliding box's pads chatter; here the impedance rises
        from 0.5 to 0.99 over the first 1 mm of penetration: a rubber-like pad that sinks
        0.58 mm at 10 N and stays in contact while the box slides.
    noslip_iterations: MuJoCo's no-slip post-solver (0 = off; 2 removes the creep, a variant).
    pad_mass_kg: mass of each pad on its slide joint. pad_thickness_m: along the grip axis.
    box_width_m: the box across the grip (between the pads).
    pad_travel_m: how far a pad may move past the box's surface once nothing stops it
        (its joint limit, so that a pad does not fly off after the box has left).
    free_rotation: a free joint for the box (rotation allowed) instead of three slides.
    pad_damping_n_s_m: viscous damping of the pads' slide joints (0: none).
    """

    timestep_s: float = 0.001
    integrator: str = "Euler"
    impratio: float = 200.0
    solref_timeconst_s: float = 0.004
    solref_dampratio: float = 1.0
    solimp: tuple[float, float, float, float, float] = (0.5, 0.99, 0.001, 0.5, 2.0)
    noslip_iterations: int = 0
    pad_mass_kg: float = 0.02
    pad_thickness_m: float = 0.01
    box_width_m: float = 0.05
    pad_travel_m: float = 0.003
    free_rotation: bool = False
    pad_damping_n_s_m: float = 0.0

    def __post_init__(self) -> None:
        if not (0 < self.timestep_s <= 0.01 and self.impratio >= 1 and self.solref_timeconst_s >= 2 * self.timestep_s):
            raise ContactSimError("MujocoParams: need 0 < timestep_s <= 0.01, impratio >= 1 and "
                                  "solref_timeconst_s >= 2 timestep_s (MuJoCo's stability rule)")
        if min(self.pad_mass_kg, self.pad_thickness_m, self.box_width_m, self.pad_travel_m) <= 0:
            raise ContactSimError("MujocoParams: pad mass, pad thickness, box width and pad travel must be > 0")


def _vec(values) -> str:
    return " ".join(f"{float(v):.9g}" for v in values)


def pinch_mjcf(obj: ObjectParams, mu: float, params: MujocoParams = MujocoParams(), hand_mass_kg: float = 1.0,
               hand_start_m: tuple[float, float] = (0.5, 0.0), gravity_m_s2: float = 9.81) -> str:
    """The MJCF text of the pinch (see the module docstring). `mu` is the total friction
    coefficient of both pads (each pad gets mu/2); `hand_start_m` the hand's start in our
    frame (x, y down)."""
    if not (math.isfinite(mu) and mu > 0):
        raise ContactSimError(f"friction coefficient must be > 0, got {mu}")
    p = params
    hx, hz = obj.pad_extent_x_m / 2.0, obj.pad_extent_y_m / 2.0
    half_w, half_t = p.box_width_m / 2.0, p.pad_thickness_m / 2.0
    if p.free_rotation:
        box_joints = '<freejoint name="box"/>'
    else:
        box_joints = "".join(f'<joint name="box_{a}" type="slide" axis="{ax}"/>'
                             for a, ax in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))
    mu_pad = mu / 2.0
    contact = (f'condim="3" friction="{mu_pad:.9g} {mu_pad:.9g} 0 0 0" '
               f'solref="{p.solref_timeconst_s:.9g} {p.solref_dampratio:.9g}" solimp="{_vec(p.solimp)}"')
    pads, pairs, motors = [], [], []
    for name, side in (("pad_l", 1.0), ("pad_r", -1.0)):
        pads.append(
            f'<body name="{name}" pos="0 {side * (half_w + half_t):.9g} 0">'
            f'<joint name="{name}" type="slide" axis="0 {-side:g} 0" limited="true" '
            f'range="-0.01 {p.pad_travel_m:.9g}" solreflimit="0.002 1" damping="{p.pad_damping_n_s_m:.9g}"/>'
            f'<geom name="{name}" type="box" size="{_vec((hx, half_t, hz))}" mass="{p.pad_mass_kg:.9g}" '
            f'contype="0" conaffinity="0"/></body>')
        pairs.append(f'<pair geom1="{name}" geom2="box" {contact}/>')
        motors.append(f'<motor name="{name}" joint="{name}" gear="1"/>')
    return f"""<mujoco model="crosscheck_pinch">
  <option timestep="{p.timestep_s:.9g}" integrator="{p.integrator}" cone="elliptic" impratio="{p.impratio:.9g}"
          noslip_iterations="{p.noslip_iterations}" gravity="0 0 {-gravity_m_s2:.9g}"/>
  <worldbody>
    <body name="box">{box_joints}
      <geom name="box" type="box" size="{_vec((hx, half_w, hz))}" mass="{obj.mass_kg:.9g}" contype="0" conaffinity="0"/>
    </body>
    {"".join(pads)}
    <body name="hand" pos="{hand_start_m[0]:.9g} 0.2 {-hand_start_m[1]:.9g}" gravcomp="1">
      <joint name="hand_x" type="slide" axis="1 0 0"/>
      <joint name="hand_z" type="slide" axis="0 0 1"/>
      <geom name="hand" type="sphere" size="0.01" mass="{hand_mass_kg:.9g}" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <contact>{"".join(pairs)}</contact>
  <actuator>{"".join(motors)}</actuator>
</mujoco>"""


class MujocoPinch:
    """One MuJoCo pinch, stepped with the grip force, the hand's force on the box and the
    forces on the hand (all in our gripper frame; see the module docstring).

    Args:
        obj: the object (mass, pad extents); its mu_static is not used: `mu` is.
        mu: total friction coefficient of both pads (MuJoCo's one coefficient).
        params: MuJoCo's numerical and geometric choices.
        hand_mass_kg: the receiver's hand mass. hand_start_m: its start (x, y down), m.
    """

    def __init__(self, obj: ObjectParams, mu: float, params: MujocoParams = MujocoParams(),
                 hand_mass_kg: float = 1.0, hand_start_m: tuple[float, float] = (0.5, 0.0)):
        self.params = params
        self.model = mujoco.MjModel.from_xml_string(pinch_mjcf(obj, mu, params, hand_mass_kg, hand_start_m))
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._box = m.body("box").id
        box_dof = m.jnt_dofadr[m.joint("box" if params.free_rotation else "box_x").id]
        box_qpos = m.jnt_qposadr[m.joint("box" if params.free_rotation else "box_x").id]
        # Our (x, y down) ↔ MuJoCo (x, z up): position/velocity indices of x and z.
        z_off = 2
        self._qx, self._qz = box_qpos, box_qpos + z_off
        self._vx, self._vz = box_dof, box_dof + z_off
        self._hq = (m.jnt_qposadr[m.joint("hand_x").id], m.jnt_qposadr[m.joint("hand_z").id])
        self._hv = (m.jnt_dofadr[m.joint("hand_x").id], m.jnt_dofadr[m.joint("hand_z").id])
        self._hand_start = hand_start_m
        self._pad_dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in ("pad_l", "pad_r")]
        mujoco.mj_forward(m, self.data)

    # ------------------------------------------------------------------ stepping
    def settle(self, grip_force_n: float, duration_s: float = 0.1) -> None:
        """Press the pads with `grip_force_n` (N) while the box's weight is held off, until the
        pads have sunk to their equilibrium; then put the box back at rest at the origin and
        the clock at 0. Our plant starts settled (pads pressing, object at rest); so does this."""
        d, m = self.data, self.model
        weight = float(m.body_mass[self._box]) * -float(m.opt.gravity[2])
        for _ in range(max(1, int(round(duration_s / m.opt.timestep)))):
            self.step(grip_force_n, (0.0, -weight))
        d.qpos[self._qx:self._qz + 1] = 0.0
        d.qvel[:] = 0.0
        d.xfrc_applied[:] = 0.0
        d.time = 0.0
        mujoco.mj_forward(m, d)

    def step(self, grip_force_n: float, object_force_n: tuple[float, float] = (0.0, 0.0),
             hand_force_n: tuple[float, float] = (0.0, 0.0)) -> None:
        """One MuJoCo step: the pads press with `grip_force_n` (N, each pad; ≥ 0), the hand's
        force `object_force_n` acts at the box's centre and `hand_force_n` on the hand (N,
        our frame: x, y down)."""
        d = self.data
        d.ctrl[0] = d.ctrl[1] = grip_force_n
        d.xfrc_applied[self._box, 0] = object_force_n[0]
        d.xfrc_applied[self._box, 2] = -object_force_n[1]
        d.qfrc_applied[self._hv[0]] = hand_force_n[0]
        d.qfrc_applied[self._hv[1]] = -hand_force_n[1]
        mujoco.mj_step(self.model, d)

    # ------------------------------------------------------------------ state (our frame)
    @property
    def time_s(self) -> float:
        """MuJoCo's time (s)."""
        return float(self.data.time)

    def object_state(self) -> tuple[float, float, float, float]:
        """Box centre (x, y down) in m from its start, and its velocity (m/s)."""
        q, v = self.data.qpos, self.data.qvel
        return float(q[self._qx]), -float(q[self._qz]), float(v[self._vx]), -float(v[self._vz])

    def hand_state(self) -> tuple[float, float, float, float]:
        """Hand position (x, y down) in m and velocity (m/s)."""
        q, v = self.data.qpos, self.data.qvel
        return (self._hand_start[0] + float(q[self._hq[0]]), self._hand_start[1] - float(q[self._hq[1]]),
                float(v[self._hv[0]]), -float(v[self._hv[1]]))

    def footprint_m(self) -> tuple[float, float]:
        """How far the box can move along x and along y (down) before its face no longer
        overlaps the pads' (m): box plus pad half-extents, read back from the model."""
        size = self.model.geom_size
        box, pad = size[self.model.geom("box").id], size[self.model.geom("pad_l").id]
        return float(box[0] + pad[0]), float(box[2] + pad[2])

    def pad_contacts(self) -> int:
        """Active pad–box contact points now (MuJoCo's collision result)."""
        return int(self.data.ncon)

    def pad_forces_n(self) -> tuple[float, float]:
        """Total normal force and total tangential (friction) force magnitude of the pads on
        the box (N), summed over the contact points of both pads."""
        d, m = self.data, self.model
        normal, tangential = 0.0, np.zeros(3)
        f6 = np.zeros(6)
        for i in range(d.ncon):
            mujoco.mj_contactForce(m, d, i, f6)
            frame = d.contact[i].frame.reshape(3, 3)
            normal += f6[0]
            tangential += f6[1] * frame[1] + f6[2] * frame[2]
        return normal, float(np.hypot(tangential[0], tangential[2]))

    def pad_load_n(self) -> tuple[float, float]:
        """Load the box puts on the pads during the last step (N, our frame: x, y down): minus
        the pads' summed force on the box in the plane of the pull, read from MuJoCo's
        constraint forces on the box's x and z degrees of freedom (the pad contacts are the
        only constraints on them). At rest under gravity alone it is (0, M g)."""
        f = self.data.qfrc_constraint
        return -float(f[self._vx]), float(f[self._vz])

    def pad_press_n(self) -> float:
        """How hard the pads press on the box during the last step (N, the mean of both
        pads' normal forces): minus the constraint force on each pad's slide joint. F_G at
        rest; 0 once the pads no longer touch (or only touch) the box."""
        f = self.data.qfrc_constraint
        return -0.5 * (float(f[self._pad_dofs[0]]) + float(f[self._pad_dofs[1]]))

    def box_rotation_rad(self) -> float:
        """Rotation of the box about the grip axis (rad; 0 unless `free_rotation`)."""
        if not self.params.free_rotation:
            return 0.0
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, self.data.qpos[self._qx + 3:self._qx + 7])
        return float(math.atan2(rot[2], rot[0]))
