"""The named release controllers (FS1, HI, SG, ...): build one by name, with parameter
overrides, or list them."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

from services.gripper.controllers.baselines import DisplacementRelease, ForceThresholdRelease, TimedRelease
from services.gripper.controllers.common import DEFAULT_PERIOD_S, ModeReportingController
from services.gripper.controllers.fail_safe import FS_PRESETS, FailSafeController
from services.gripper.controllers.human_inspired import HumanInspiredController, HumanInspiredParams
from services.gripper.controllers.slip_guard import SG_PRESETS, SlipGuardController
from services.gripper.controllers.tuned import load_presets
from services.gripper.errors import GripperError


@dataclass(frozen=True)
class _Entry:
    factory: Callable[..., ModeReportingController]
    summary: str
    defaults: dict = field(default_factory=dict)


def _preset_factory(preset: str, presets: dict, controller: Callable[..., ModeReportingController],
                    params_doc: str) -> Callable[..., ModeReportingController]:
    """Builder of a named parameter preset (FS1, SG, ...), with keyword overrides."""
    def build(period_s: float = DEFAULT_PERIOD_S, **overrides) -> ModeReportingController:
        try:
            params = replace(presets[preset], **overrides)
        except TypeError as exc:
            raise GripperError(f"{preset}: unknown parameter ({exc}); see {params_doc}") from None
        return controller(params, period_s=period_s)

    return build


def _fs_factory(preset: str) -> Callable[..., ModeReportingController]:
    return _preset_factory(preset, FS_PRESETS, FailSafeController, "FailSafeParams")


def _hi_factory(period_s: float = DEFAULT_PERIOD_S, **overrides) -> ModeReportingController:
    try:
        params = HumanInspiredParams(**overrides)
    except TypeError as exc:
        raise GripperError(f"HI: unknown parameter ({exc}); see HumanInspiredParams") from exc
    return HumanInspiredController(params, period_s=period_s)


def _sg_factory(preset: str) -> Callable[..., ModeReportingController]:
    return _preset_factory(preset, SG_PRESETS, SlipGuardController, "SlipGuardParams")


def _kw_factory(cls) -> Callable[..., ModeReportingController]:
    def build(period_s: float = DEFAULT_PERIOD_S, **overrides) -> ModeReportingController:
        try:
            return cls(period_s=period_s, **overrides)
        except TypeError as exc:
            raise GripperError(f"{cls.__name__}: unknown parameter ({exc})") from exc

    return build


_REGISTRY: dict[str, _Entry] = {
    "FS1": _Entry(_fs_factory("FS1"), "fail-safe eq 3.19, α=10 β=3 γ=3 F_margin=15 N k_i=0.13 (§3.6.1.1)"),
    "FS2": _Entry(_fs_factory("FS2"), "FS1 with α=15 (§3.6.1.1)"),
    "FS3": _Entry(_fs_factory("FS3"), "FS1 with γ=1 (§3.6.1.1)"),
    "FS-sim-g1": _Entry(_fs_factory("FS-sim-g1"), "§3.5 simulation set as printed in Table IV (γ=1, F_margin=12 N)"),
    "FS-sim-g5": _Entry(_fs_factory("FS-sim-g5"), "§3.5 simulation set as stated in the text (γ=5, F_margin=12 N)"),
    "HI": _Entry(_hi_factory, "human-inspired, Chan et al. eq 3.22: F_Go=15 N, ε=−2 N, F_ZLG=5 N"),
    "timed": _Entry(_kw_factory(TimedRelease), "baseline: release at a fixed time (2 s)"),
    "force-threshold": _Entry(_kw_factory(ForceThresholdRelease), "baseline: release when |ΔF| ≥ 3 N (Deyle et al.)"),
    "displacement": _Entry(
        _kw_factory(DisplacementRelease), "baseline: impedance hand displaced ≥ 1 cm (Bohren et al.)"
    ),
    "SG": _Entry(_sg_factory("SG"), "ours, version 3: slip-guarded load share (weight-scaled hold capped at 20 N, "
                                    "slip-velocity guard and catch)"),
    "SG-v2": _Entry(_sg_factory("SG-v2"), "ours, version 2 (kept for comparison): c_hold=4, no hold cap, s_cap=3"),
}



def _tuned_factory(name: str, base: str, params: dict) -> Callable[..., ModeReportingController]:
    """Builder of a tuned preset (`tuned_presets.json`): its base controller with the tuned
    parameters, then any overrides."""
    def build(period_s: float = DEFAULT_PERIOD_S, **overrides) -> ModeReportingController:
        if base not in _REGISTRY or base in _TUNED:
            raise GripperError(f"tuned preset {name!r}: unknown base controller {base!r}")
        return _REGISTRY[base].factory(period_s=period_s, **{**params, **overrides})

    return build


def _register_tuned() -> set[str]:
    names = set()
    for name, entry in load_presets().items():
        if name in _REGISTRY:
            raise GripperError(f"tuned preset {name!r} would shadow a built-in controller; rename it")
        prov = entry.get("provenance", {})
        summary = (f"{entry['base']} tuned by `handover-study tune` (CMA-ES, seed {prov.get('seed', '?')}, "
                   f"{prov.get('episodes', '?')} episodes of {prov.get('population', '?')})")
        _REGISTRY[name] = _Entry(_tuned_factory(name, entry["base"], entry["params"]), summary)
        names.add(name)
    return names


_TUNED: set[str] = set()
_TUNED |= _register_tuned()
CONTROLLER_NAMES: tuple[str, ...] = tuple(_REGISTRY)


def controller_summaries() -> dict[str, str]:
    """Name → one-line description of every registered controller."""
    return {name: entry.summary for name, entry in _REGISTRY.items()}


def make_controller(name: str, period_s: float = DEFAULT_PERIOD_S, **overrides) -> ModeReportingController:
    """Build a registered controller by name, with optional parameter overrides.

    Raises GripperError for an unknown name or parameter.
    """
    try:
        entry = _REGISTRY[name]
    except KeyError:
        raise GripperError(
            f"unknown controller {name!r}; choose one of: {', '.join(CONTROLLER_NAMES)}"
        ) from None
    return entry.factory(period_s=period_s, **overrides)
