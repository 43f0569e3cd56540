"""The DJT reference of an evaluation episode (`services.studies.evaluation.djt_reference`)."""

from __future__ import annotations

import dataclasses

from services.studies.evaluation.djt_reference import djt_optimum_base_m
from services.studies.evaluation.population import draw_episode


def test_a_receiver_no_point_suits_has_no_reference_instead_of_failing_the_run():
    """A 1.51 m sitting receiver (seed 1, episode 36 of the default population) shares no
    reachable point with the robot above the table: the episode gets no reference (its
    transfer-point error is n/a) and the run goes on; a standing 1.75 m one gets a point in
    front of the robot, within its reach."""
    small = draw_episode(1, 36)
    assert (small.posture, round(small.height_m, 3)) == ("sitting", 1.514)
    assert djt_optimum_base_m(small, {}) is None
    tall = dataclasses.replace(small, posture="standing", height_m=1.75)
    point = djt_optimum_base_m(tall, {})
    assert point is not None and 0.2 < point[0] < 1.2 and abs(point[2]) < 0.8
