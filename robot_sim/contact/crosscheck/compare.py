"""Run each scenario on both plants and compare what `measure` reads, quantity by quantity,
against tolerances stated before the runs (`QUANTITIES`).

A row: scenario, quantity, ours, MuJoCo, difference (MuJoCo − ours), tolerance, agree. A
boolean quantity agrees when both plants say the same; a number when |difference| ≤
max(absolute tolerance, relative tolerance × |ours|); "none" on both sides (e.g. no slip
onset in either run) agrees, "none" on one side does not. A case may expect a disagreement
(`Case.expect_agree = False`): a known modelling difference, explained in its note and in the
docs, that the comparison must show, not hide (`problems` reports it if it does not show).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, fields, replace

import numpy as np

from robot_sim.contact.config import SimConfig
from robot_sim.contact.crosscheck.measure import in_pad_gap_mm, measure
from robot_sim.contact.crosscheck.mjcf import MujocoParams
from robot_sim.contact.crosscheck.runs import Run, run_mujoco, run_ours
from robot_sim.contact.crosscheck.scenario import Scenario

__all__ = ["Tolerance", "QUANTITIES", "Case", "Row", "CaseResult", "compare_case", "compare_all", "problems"]


@dataclass(frozen=True)
class Tolerance:
    """|MuJoCo − ours| ≤ max(abs_, rel × |ours|) (units of the quantity); booleans must match."""

    abs_: float = 0.0
    rel: float = 0.0

    def allows(self, ours: float | bool, theirs: float | bool) -> bool:
        """Whether the two values agree within this tolerance."""
        if isinstance(ours, bool) or isinstance(theirs, bool):
            return bool(ours) == bool(theirs)
        if math.isnan(ours) or math.isnan(theirs):
            return math.isnan(ours) and math.isnan(theirs)
        return abs(theirs - ours) <= max(self.abs_, self.rel * abs(ours)) + 1e-12

    def text(self, unit: str) -> str:
        """The tolerance as a short text (e.g. "±2 %", "±5 ms", "equal")."""
        if self.abs_ == 0.0 and self.rel == 0.0:
            return "equal"
        parts = []
        if self.rel:
            parts.append(f"±{100 * self.rel:g} %")
        if self.abs_:
            scale, shown = (1e3, "ms") if unit == "s" else (1.0, unit)
            parts.append(f"±{scale * self.abs_:g} {shown}")
        return " or ".join(parts)


#: key → (label, unit, tolerance). The tolerances are the cross-check's claims: slip onset
#: within 2 % (μ identified to 2 %), event times within 5 plant steps, distances within 1 mm
#: or 5 %, forces within 2 %, and the two trajectories within 0.5 mm while between the pads.
QUANTITIES: dict[str, tuple[str, str, Tolerance]] = {
    "onset_pull_n": ("slip-onset pull F_p", "N", Tolerance(abs_=0.02, rel=0.02)),
    "onset_time_s": ("slip-onset time", "s", Tolerance(abs_=0.005)),
    "left": ("left the pads", "", Tolerance()),
    "leave_time_s": ("time it leaves the pads", "s", Tolerance(abs_=0.005)),
    "slide_distance_mm": ("slide distance (to leaving or rest)", "mm", Tolerance(abs_=1.0, rel=0.05)),
    "caught": ("caught (re-stuck in the pads)", "", Tolerance()),
    "dropped": ("dropped", "", Tolerance()),
    "drop_time_s": ("drop time", "s", Tolerance(abs_=0.005)),
    "handed_over": ("handed over", "", Tolerance()),
    "overshoot_n": ("force overshoot (max hand force in the pads)", "N", Tolerance(abs_=0.05, rel=0.02)),
    "in_pad_gap_mm": ("largest position gap while in the pads", "mm", Tolerance(abs_=0.5)),
}


@dataclass(frozen=True)
class Case:
    """A scenario, how MuJoCo runs it, and what the comparison should find.

    group: a label for tables and plots. mujoco: MuJoCo's parameters. mujoco_mu: MuJoCo's
    friction coefficient if not the scenario's (a deliberately wrong μ). expect_agree: False
    for a known modelling difference (`note` says which)."""

    scenario: Scenario
    group: str
    mujoco: MujocoParams = field(default_factory=MujocoParams)
    mujoco_mu: float | None = None
    expect_agree: bool = True
    note: str = ""


@dataclass(frozen=True)
class Row:
    """One line of the comparison table (values in the quantity's unit; NaN = none)."""

    group: str
    scenario: str
    quantity: str
    label: str
    unit: str
    ours: float | bool
    mujoco: float | bool
    tolerance: str
    agree: bool
    expect_agree: bool
    note: str = ""

    @property
    def difference(self) -> float | None:
        """MuJoCo − ours (None for booleans)."""
        if isinstance(self.ours, bool) or isinstance(self.mujoco, bool):
            return None
        return float(self.mujoco) - float(self.ours)


@dataclass(frozen=True)
class CaseResult:
    """A case's rows and both runs (kept for the plots)."""

    case: Case
    rows: list[Row]
    ours: Run
    mujoco: Run


def compare_case(case: Case, sim: SimConfig = SimConfig()) -> CaseResult:
    """Run `case` on both plants and compare every quantity of its kind."""
    sc = case.scenario
    ours = run_ours(sc, sim)
    theirs = run_mujoco(sc, sim, case.mujoco, case.mujoco_mu)
    a, b = measure(sc, ours), measure(sc, theirs)
    if sc.kind != "onset":
        a["in_pad_gap_mm"], b["in_pad_gap_mm"] = 0.0, in_pad_gap_mm(ours, theirs)
    rows = []
    for key in a:
        label, unit, tol = QUANTITIES[key]
        rows.append(Row(case.group, sc.name, key, label, unit, a[key], b[key], tol.text(unit),
                        tol.allows(a[key], b[key]), case.expect_agree, case.note))
    return CaseResult(case, rows, ours, theirs)


def compare_all(cases: Iterable[Case], sim: SimConfig = SimConfig(), keep_runs=lambda case: True,
                progress=None) -> list[CaseResult]:
    """`compare_case` for every case; runs of cases `keep_runs` rejects are dropped (memory)."""
    out = []
    for case in cases:
        res = compare_case(case, sim)
        if not keep_runs(case):
            res = CaseResult(res.case, res.rows, _empty(res.ours), _empty(res.mujoco))
        out.append(res)
        if progress is not None:
            progress(res)
    return out


def _empty(run: Run) -> Run:
    """The run without its time series (its plant and footprint only)."""
    return replace(run, **{f.name: getattr(run, f.name)[:0] for f in fields(run)
                           if isinstance(getattr(run, f.name), np.ndarray)})


def problems(results: Sequence[CaseResult]) -> list[str]:
    """What the comparison did not find as expected, one line each: a row of a case that
    should agree but disagrees, or a known modelling difference that did not show (a case
    expecting a disagreement whose rows all agree). Empty when all is as stated."""
    out = []
    for res in results:
        if res.case.expect_agree:
            out += [f"{r.scenario}: {r.label} disagrees (ours {r.ours}, MuJoCo {r.mujoco}, {r.tolerance})"
                    for r in res.rows if not r.agree]
        elif all(r.agree for r in res.rows):
            out.append(f"{res.case.scenario.name}: expected a disagreement ({res.case.note}) but all agree")
    return out
