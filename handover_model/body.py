"""The human body model: ONE anthropometric table for every part of the stack.

The planner's DJT arm (`services.planner.anthropometrics`), the simulated receiver
(`robot_sim.kinect.receiver`) and the tracker's body-dimension estimator
(`services.tracker.body`) all read their proportions here, so the body the simulator draws is
the body the tracker measures and the planner reasons about.

Segment lengths and joint heights: Drillis & Contini (1966), "Body segment parameters",
Report 1166-03, New York University, as reproduced in D. A. Winter, *Biomechanics and Motor
Control of Human Movement*, 4th ed., Fig. 4.1 (fractions of stature H):

    shoulder (joint-to-joint) width 0.259 H, upper arm 0.186 H, forearm 0.146 H,
    hand (wrist to fingertip) 0.108 H; heights of the shoulder 0.818 H, hip 0.530 H,
    knee 0.285 H, ankle 0.039 H.

Taken literally the upper-limb chain spans 0.259 + 2·(0.186 + 0.146 + 0.108) = 1.139 H
fingertip to fingertip, whereas measured arm spans are close to H (0.95–1.06 H). The whole
chain is therefore scaled uniformly to the measured arm span L: each upper-limb length is
``fraction · L / 1.139`` (`upper_limb_m`). The simulated receiver has the average adult's
arm span, L = H (`AVERAGE_SPAN_TO_HEIGHT`).

Two joints of the OpenNI skeleton that the table does not define are conventions of this model:
the torso joint at 0.670 H and the head joint (the head's centre) at 0.930 H, and the hip
joints 0.050 H either side of the mid-line (joint centres, not the hips' outer width).

Segment masses and centres of mass: Dempster (1955) via Winter, Table 4.1 (fractions of body
mass W; centre of mass as a fraction of the segment length from its proximal joint).
Sitting shoulder height: Pheasant & Haslegrave, *Bodyspace*, 3rd ed.: about 0.34 H above the
seat. Forward lean of the upper body toward a partner: at most 0.04 H at the shoulders.

Units: fractions of H (dimensionless) unless the name says otherwise; lengths in metres.
"""

from __future__ import annotations

from dataclasses import dataclass

# Drillis & Contini (1966), fractions of stature H (Winter, Fig. 4.1).
SHOULDER_WIDTH_FRACTION = 0.259
UPPER_ARM_FRACTION = 0.186
FOREARM_FRACTION = 0.146
HAND_FRACTION = 0.108
SHOULDER_HEIGHT_FRACTION = 0.818
HIP_HEIGHT_FRACTION = 0.530
KNEE_HEIGHT_FRACTION = 0.285
ANKLE_HEIGHT_FRACTION = 0.039
#: Fingertip-to-fingertip span of the table's upper-limb chain, fraction of H.
TABLE_SPAN_FRACTION = SHOULDER_WIDTH_FRACTION + 2.0 * (UPPER_ARM_FRACTION + FOREARM_FRACTION + HAND_FRACTION)

# Skeleton conventions of this model (OpenNI joints the table does not define).
TORSO_JOINT_HEIGHT_FRACTION = 0.670
HEAD_JOINT_HEIGHT_FRACTION = 0.930
HIP_JOINT_HALF_WIDTH_FRACTION = 0.050

#: The average adult's arm span over height, and the simulated receiver's.
AVERAGE_SPAN_TO_HEIGHT = 1.0

# Dempster (1955) via Winter, Table 4.1.
UPPER_ARM_MASS_FRACTION = 0.028
UPPER_ARM_COM_FRACTION = 0.436
FOREARM_HAND_MASS_FRACTION = 0.022
FOREARM_HAND_COM_FRACTION = 0.682

# Pheasant & Haslegrave, Bodyspace: sitting shoulder height above the seat, fraction of H.
SITTING_SHOULDER_ABOVE_SEAT_FRACTION = 0.34

#: Largest forward lean of the shoulders toward a target beyond the straight arm, fraction
#: of H (trunk flexion about the hips). The planner assumes the same by default.
MAX_LEAN_FRACTION = 0.04


@dataclass(frozen=True)
class UpperLimb:
    """One side's upper limb scaled to an arm span, metres.

    Attributes:
        shoulder_half_width_m: mid-line → shoulder joint.
        upper_arm_m: shoulder joint → elbow joint.
        forearm_m: elbow joint → wrist.
        hand_m: wrist → fingertip.
    """

    shoulder_half_width_m: float
    upper_arm_m: float
    forearm_m: float
    hand_m: float

    @property
    def elbow_to_palm_centre_m(self) -> float:
        """Elbow joint → the hand's centre (the OpenNI hand joint), m."""
        return self.forearm_m + 0.5 * self.hand_m

    @property
    def palm_centre_to_fingertip_m(self) -> float:
        """The hand's centre → fingertip, m."""
        return 0.5 * self.hand_m


def upper_limb_m(arm_span_m: float) -> UpperLimb:
    """The table's upper limb scaled so that fingertip to fingertip spans `arm_span_m` (m)."""
    scale = arm_span_m / TABLE_SPAN_FRACTION
    return UpperLimb(
        shoulder_half_width_m=0.5 * SHOULDER_WIDTH_FRACTION * scale,
        upper_arm_m=UPPER_ARM_FRACTION * scale,
        forearm_m=FOREARM_FRACTION * scale,
        hand_m=HAND_FRACTION * scale,
    )


#: The average adult's upper limb, fractions of H (`upper_limb_m` at L = H, per metre of H).
AVERAGE_UPPER_LIMB = upper_limb_m(AVERAGE_SPAN_TO_HEIGHT)
