"""What the contact plant reports after a step: sensors and ground truth (`Observation`)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Observation"]


@dataclass(frozen=True)
class Observation:
    """Everything one plant step produces, for one episode (floats) or a batch (arrays).

    Sensors (what a real robot would have), gripper frame x toward receiver, y down:
        time_s; wrist_force_x_n, wrist_force_y_n (F/T, with noise and bias; held between
        samples); ft_fresh (a new F/T sample was taken in the last advance);
        optical_counts_x, optical_counts_y (last register read, counts);
        optical_counts_per_m; optical_dt_s (report period); optical_valid;
        slip_velocity_x_m_s, slip_velocity_y_m_s, accel_y_m_s2 (estimates);
        optical_fresh; gripper_finger_m (finger position − contact position x0, m);
        grip_force_estimate_n (spring force from the finger position, N).
    Ground truth (never for control):
        mode (Mode value); grip_force_n (force the pads really apply); object_position_x_m,
        object_position_y_m (displacement from the start, m); object_velocity_x_m_s,
        object_velocity_y_m_s; object_accel_x_m_s2, object_accel_y_m_s2; hand_position_x_m,
        hand_position_y_m (receiver hand, same frame); pull_force_x_n, pull_force_y_n
        (receiver's force on the object); true_wrist_force_x_n, true_wrist_force_y_n;
        receiver_grasp (0..1); receiver_holds; left_pads; dropped.
    """

    time_s: float
    wrist_force_x_n: object
    wrist_force_y_n: object
    ft_fresh: bool
    optical_counts_x: object
    optical_counts_y: object
    optical_counts_per_m: float
    optical_dt_s: float
    optical_valid: object
    slip_velocity_x_m_s: object
    slip_velocity_y_m_s: object
    accel_y_m_s2: object
    optical_fresh: bool
    gripper_finger_m: object
    grip_force_estimate_n: object
    mode: object
    grip_force_n: object
    object_position_x_m: object
    object_position_y_m: object
    object_velocity_x_m_s: object
    object_velocity_y_m_s: object
    object_accel_x_m_s2: object
    object_accel_y_m_s2: object
    hand_position_x_m: object
    hand_position_y_m: object
    pull_force_x_n: object
    pull_force_y_n: object
    true_wrist_force_x_n: object
    true_wrist_force_y_n: object
    receiver_grasp: object
    receiver_holds: object
    left_pads: object
    dropped: object
