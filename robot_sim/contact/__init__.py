"""Realistic contact simulator for the object-transfer phase of a handover (issue 3).

Plant (object between two friction pads, gravity, Coulomb stick/slip, pad extent, free
fall, receiver hand), gripper actuator (thesis eq 3.21 spring, 25 Hz position loop, speed
limit), receiver behaviours, sensors (wrist F/T, ADNS-2051-class optical sensor), outcome
from ground truth, and a vectorised, seedable, parallel batch runner. Usable without any bus.
"""

from handover_model.grip import GripController, Mode, SensorSample
from robot_sim.contact.outcome import (
    BatchOutcome,
    EpisodeOutcome,
    EpisodeTrace,
    OutcomeAccumulator,
    outcome_from_trace,
)

__all__ = [
    "GripController",
    "Mode",
    "SensorSample",
    "BatchOutcome",
    "EpisodeOutcome",
    "EpisodeTrace",
    "OutcomeAccumulator",
    "outcome_from_trace",
]
