"""Tuned presets (services/gripper/controllers/tuned.py) and their registry entries."""

from __future__ import annotations

import json

import pytest

from services.gripper.controllers.registry import CONTROLLER_NAMES, make_controller
from services.gripper.controllers.tuned import PRESETS_PATH, load_presets, save_preset
from services.gripper.errors import GripperError


def test_save_keeps_other_presets_and_loads_back(tmp_path):
    path = tmp_path / "p.json"
    assert load_presets(path) == {}
    save_preset("A", "SG", {"hold_per_weight": 7.0}, {"seed": 1000}, path)
    save_preset("B", "HI", {"initial_grip_force_n": 12.0}, {}, path)
    doc = load_presets(path)
    assert doc["A"]["params"] == {"hold_per_weight": 7.0} and doc["B"]["base"] == "HI"


@pytest.mark.parametrize("text, message", [
    ("{not json", "cannot read"),
    ('{"X": {"params": {}}}', "needs a 'base'"),
    ('{"X": {"base": "SG", "params": {"hold_per_weight": "big"}}}', "not a finite number"),
    ("[1, 2]", "expected an object"),
])
def test_bad_preset_files_say_what_is_wrong(tmp_path, text, message):
    path = tmp_path / "p.json"
    path.write_text(text)
    with pytest.raises(GripperError, match=message):
        load_presets(path)


def test_every_shipped_preset_is_registered_with_its_parameters():
    shipped = json.loads(PRESETS_PATH.read_text())
    assert {"SG-tuned", "HI-tuned"} <= set(shipped)
    for name, entry in shipped.items():
        assert name in CONTROLLER_NAMES
        ctrl = make_controller(name, period_s=0.004)
        assert ctrl.period_s == 0.004
        for key, value in entry["params"].items():
            assert getattr(ctrl.params, key) == pytest.approx(value)  # type: ignore[attr-defined]


def test_overrides_apply_on_top_of_a_tuned_preset():
    ctrl = make_controller("SG-tuned", release_share=0.42)
    assert ctrl.params.release_share == 0.42  # type: ignore[attr-defined]
    with pytest.raises(GripperError, match="unknown parameter"):
        make_controller("SG-tuned", no_such_parameter=1.0)
