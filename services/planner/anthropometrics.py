"""Body dimensions → the planar two-link arm of the DJT model (thesis §2.2–2.3).

The thesis measures each actor's height H, arm span L, weight W (and waistline height) and
derives the arm's link lengths "from studies that relate the length of each link in the human
arm to height and arm span" (its ref. [40]), and the link masses from the body weight. The
proportions come from the stack's one anthropometric table, `handover_model.body` (Drillis &
Contini segment lengths, Dempster masses and centres of mass, Pheasant's sitting shoulder
height; the sources are named there):

- link lengths from the arm span: the table's upper-limb chain scaled to span L
  (`handover_model.body.upper_limb_m`); shoulder height from the height H (0.818 H standing;
  the seat height + 0.34 H sitting);
- link masses and centres of mass from the weight W: upper arm 0.028 W, centre of mass 0.436
  from the shoulder; forearm and hand 0.022 W, centre of mass 0.682 of the forearm from the
  elbow.

The distal link of the model ends at the grasp point, a configurable fraction of the hand
length beyond the wrist (default 0.5: the middle of the hand, where a cup is held).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from handover_model.body import (
    FOREARM_HAND_COM_FRACTION,
    FOREARM_HAND_MASS_FRACTION,
    SHOULDER_HEIGHT_FRACTION,
    SITTING_SHOULDER_ABOVE_SEAT_FRACTION,
    UPPER_ARM_COM_FRACTION,
    UPPER_ARM_MASS_FRACTION,
    upper_limb_m,
)
from services.planner.errors import PlannerError

Posture = Literal["standing", "sitting"]

#: Plausible human bodies (inclusive). Outside these the inputs are most likely a unit
#: mistake (cm for m, lb for kg) or a tracking failure.
HEIGHT_RANGE_M = (1.0, 2.5)
WEIGHT_RANGE_KG = (20.0, 300.0)
#: Arm span / height ("ape index"); adults lie within about 0.90–1.10.
SPAN_TO_HEIGHT_RANGE = (0.85, 1.15)
SEAT_HEIGHT_RANGE_M = (0.2, 1.0)

DEFAULT_SEAT_HEIGHT_M = 0.45
DEFAULT_GRASP_FRACTION_OF_HAND = 0.5


@dataclass(frozen=True)
class BodyDimensions:
    """An actor's measured body.

    Attributes:
        height_m: stature H, m.
        arm_span_m: fingertip-to-fingertip arm span L, m.
        weight_kg: body mass W, kg.
        posture: ``standing`` or ``sitting``.
        seat_height_m: seat height above the floor when sitting, m (ignored when standing).
    """

    height_m: float
    arm_span_m: float
    weight_kg: float
    posture: Posture = "standing"
    seat_height_m: float = DEFAULT_SEAT_HEIGHT_M

    def __post_init__(self) -> None:
        validate_body(self)


def _check_range(name: str, value: float, bounds: tuple[float, float], unit: str) -> None:
    lo, hi = bounds
    if not (lo <= value <= hi):  # also rejects NaN
        raise PlannerError(
            f"{name} = {value:g} {unit} is not a plausible human value "
            f"(expected {lo:g}–{hi:g} {unit}); check the units (metres, kilograms)"
        )


def validate_body(body: BodyDimensions) -> None:
    """Raise PlannerError when `body` cannot be a human body.

    Checks height, weight, arm span relative to height, posture and seat height.
    """
    _check_range("height", body.height_m, HEIGHT_RANGE_M, "m")
    _check_range("weight", body.weight_kg, WEIGHT_RANGE_KG, "kg")
    if not (body.arm_span_m > 0.0):
        raise PlannerError(f"arm span = {body.arm_span_m:g} m must be positive")
    ratio = body.arm_span_m / body.height_m
    lo, hi = SPAN_TO_HEIGHT_RANGE
    if not (lo <= ratio <= hi):
        raise PlannerError(
            f"arm span {body.arm_span_m:.2f} m is {ratio:.2f} × the height {body.height_m:.2f} m; "
            f"human arm spans are {lo:g}–{hi:g} × height: check both measurements"
        )
    if body.posture not in ("standing", "sitting"):
        raise PlannerError(f"posture {body.posture!r} must be 'standing' or 'sitting'")
    if body.posture == "sitting":
        _check_range("seat height", body.seat_height_m, SEAT_HEIGHT_RANGE_M, "m")


@dataclass(frozen=True)
class PlanarArm:
    """The planar two-link arm of one actor (thesis §2.2 assumption 3).

    Attributes:
        upper_arm_m: shoulder → elbow length l1, m.
        forearm_to_grasp_m: elbow → grasp point length l2, m.
        upper_arm_mass_kg: m1, kg.
        forearm_hand_mass_kg: m2 (forearm and hand), kg.
        upper_arm_com_m: shoulder → upper-arm centre of mass c1, m.
        forearm_hand_com_m: elbow → forearm-and-hand centre of mass c2, m.
        shoulder_height_m: shoulder joint height above the floor, m.
    """

    upper_arm_m: float
    forearm_to_grasp_m: float
    upper_arm_mass_kg: float
    forearm_hand_mass_kg: float
    upper_arm_com_m: float
    forearm_hand_com_m: float
    shoulder_height_m: float

    @property
    def reach_m(self) -> float:
        """Shoulder → grasp point distance with the elbow straight, m."""
        return self.upper_arm_m + self.forearm_to_grasp_m

    @property
    def min_reach_m(self) -> float:
        """Shoulder → grasp point distance with the elbow fully folded, m."""
        return abs(self.upper_arm_m - self.forearm_to_grasp_m)


def shoulder_height_m(body: BodyDimensions) -> float:
    """Shoulder joint height above the floor, m (Drillis & Contini standing; Pheasant sitting)."""
    if body.posture == "sitting":
        return body.seat_height_m + SITTING_SHOULDER_ABOVE_SEAT_FRACTION * body.height_m
    return SHOULDER_HEIGHT_FRACTION * body.height_m


def planar_arm(
    body: BodyDimensions,
    grasp_fraction_of_hand: float = DEFAULT_GRASP_FRACTION_OF_HAND,
    shoulder_height_override_m: float | None = None,
) -> PlanarArm:
    """The two-link arm of `body`.

    Args:
        body: the actor's dimensions (validated).
        grasp_fraction_of_hand: grasp point as a fraction of the hand length (wrist →
            fingertip) beyond the wrist, 0..1.
        shoulder_height_override_m: a measured shoulder height above the floor (m) to use
            instead of the table's estimate (e.g. from the skeleton tracker).

    Raises:
        PlannerError: on an implausible body or grasp fraction.
    """
    validate_body(body)
    if not (0.0 <= grasp_fraction_of_hand <= 1.0):
        raise PlannerError(
            f"grasp fraction of hand = {grasp_fraction_of_hand:g} must be within 0..1"
        )
    limb = upper_limb_m(body.arm_span_m)
    upper_arm, forearm, hand = limb.upper_arm_m, limb.forearm_m, limb.hand_m
    if shoulder_height_override_m is not None:
        _check_range("shoulder height", shoulder_height_override_m, (0.3, 2.2), "m")
        shoulder = shoulder_height_override_m
    else:
        shoulder = shoulder_height_m(body)
    return PlanarArm(
        upper_arm_m=upper_arm,
        forearm_to_grasp_m=forearm + grasp_fraction_of_hand * hand,
        upper_arm_mass_kg=UPPER_ARM_MASS_FRACTION * body.weight_kg,
        forearm_hand_mass_kg=FOREARM_HAND_MASS_FRACTION * body.weight_kg,
        upper_arm_com_m=UPPER_ARM_COM_FRACTION * upper_arm,
        forearm_hand_com_m=FOREARM_HAND_COM_FRACTION * forearm,
        shoulder_height_m=shoulder,
    )


#: The robot giver of §2.5: "a human with height = 190 cm, weight = 100 kg, arm span = 200 cm".
ROBOT_AS_HUMAN = BodyDimensions(height_m=1.90, arm_span_m=2.00, weight_kg=100.0)
#: The actors of thesis Figure 3: H = 187 cm, L = 190 cm, W = 80 kg.
FIGURE3_ACTOR = BodyDimensions(height_m=1.87, arm_span_m=1.90, weight_kg=80.0)
