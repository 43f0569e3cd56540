"""The camera path's body-pose model on real photographs shipped by registry packages
(scikit-image, matplotlib): joints inside hand-checked boxes, nobody in a photo of a cat or a
cup, two people in two photos side by side."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mediapipe", reason="the camera extra is not installed: pip install -e '.[camera]' && "
                                        "pip install --no-deps mediapipe==0.10.14 (docs/camera.md#install)")
pytest.importorskip("skimage", reason="the camera extra (scikit-image's photos) is not installed")

from services.tracker.camera import photos  # noqa: E402
from services.tracker.camera.pose2d import LM, PoseEstimator  # noqa: E402


@pytest.fixture(scope="module")
def estimator():
    est = PoseEstimator(max_people=3)
    yield est
    est.close()


def assert_in_box(name, person, placed=None):
    for joint, label in photos.LABELS[name].items():
        expected = placed.label_px(joint) if placed is not None else np.asarray(label, float)
        got, vis = person.point(joint)
        assert vis >= 0.3, f"{name} {joint}: visibility {vis:.2f}"
        assert np.all(np.abs(got - expected) <= photos.HALF_BOX_PX), f"{name} {joint}: {got} vs label {expected}"


@pytest.mark.parametrize("name", ["astronaut", "cameraman", "hopper"])
def test_one_person_joints_fall_in_the_hand_checked_boxes(estimator, name):
    people = estimator.people(photos.photo(name))
    assert len(people) == 1
    assert_in_box(name, people[0])


def test_the_astronauts_hidden_arm_is_reported_hidden(estimator):
    person = estimator.people(photos.photo("astronaut"))[0]
    for joint in ("left_wrist", "left_pinky", "left_index"):  # behind the helmet
        assert person.visibility[LM[joint]] < 0.5


@pytest.mark.parametrize("name", ["cat", "coffee"])
def test_no_person_in_a_photo_of_a_cat_or_a_cup(estimator, name):
    assert estimator.people(photos.photo(name)) == []


@pytest.mark.parametrize("left,right", [("astronaut", "hopper"), ("astronaut", "cameraman"), ("hopper", "astronaut")])
def test_two_people_side_by_side_are_both_found(estimator, left, right):
    frame, placed = photos.compose([(left, "left"), (right, "right")])
    people = estimator.people(frame)
    assert len(people) == 2
    by_side = sorted(people, key=lambda p: p.xy_px[LM["nose"]][0])
    for person, place, (x0, x1) in zip(by_side, placed, ((0, 512), (512, 1024)), strict=True):
        for joint in ("left_shoulder", "right_shoulder", "nose"):
            assert x0 <= person.point(joint)[0][0] <= x1, f"{place.name} {joint} outside its photo"
    hopper = [(p, pl) for p, pl in zip(by_side, placed, strict=True) if pl.name in ("hopper", "cameraman")]
    for person, place in hopper:  # their shoulders (and elbow) also in the boxes of the single photo
        assert_in_box(place.name, person, place)


def test_one_person_only_when_asked_for_one():
    est = PoseEstimator(max_people=1)
    frame, _ = photos.compose([("astronaut", "left"), ("hopper", "right")])
    assert len(est.people(frame)) == 1
    assert est.inferences == 1
    est.close()


def test_a_bad_image_is_refused(estimator):
    with pytest.raises(ValueError, match="uint8 RGB"):
        estimator.people(np.zeros((10, 10), np.uint8))


def test_the_shipped_sample_input_is_what_camera_sample_writes(tmp_path):
    import cv2

    repo = __import__("pathlib").Path(__file__).resolve().parents[3] / "deploy" / "camera_sample"
    assert photos.write_sample(tmp_path) == 1
    for part in ("rgb/0000.png", "depth/0000.png"):
        np.testing.assert_array_equal(cv2.imread(str(tmp_path / part), cv2.IMREAD_UNCHANGED),
                                      cv2.imread(str(repo / part), cv2.IMREAD_UNCHANGED))
    assert (tmp_path / "calibration.toml").read_text() == (repo / "calibration.toml").read_text()
