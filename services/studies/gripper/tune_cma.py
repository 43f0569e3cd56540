"""The CMA-ES loop of `handover-study tune`: ask a generation, evaluate it on the tuning episodes
in one batch, tell, and write the best-so-far to a JSON file after every generation (and the
optimiser's state next to it, so a run can be resumed).

Why CMA-ES (`cma`) and not optuna: the objective is a deterministic black box of 3–11
continuous parameters whose cost is one vectorised plant run per generation; CMA-ES asks for a
whole generation at once (it all runs in one batch), adapts to correlated parameters (a hold and
its cap trade against each other), needs no model of the search space, and `cma` depends only
on numpy. Optuna's samplers are built around one trial at a time and a storage backend, which
buys nothing here.
"""

from __future__ import annotations

import json
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import cma
import numpy as np

from services.gripper.errors import GripperError
from services.studies.gripper.tuning import Chunks, ParamSpace, Runner, evaluate

__all__ = ["TuneState", "run_cma"]

#: Initial step size in the unit cube (a quarter of each parameter's range).
SIGMA0 = 0.25


@dataclass
class TuneState:
    """What a run knows so far: the best parameters and their figures, the start's figures,
    one line per generation, and the evaluations spent."""

    controller: str
    best_params: dict[str, float]
    best: dict
    start: dict
    history: list[dict] = field(default_factory=list)
    evaluations: int = 0
    best_rerun: dict | None = None

    def to_json(self, provenance: dict) -> dict:
        return {"controller": self.controller, "best_params": self.best_params, "best": self.best,
                "best_rerun": self.best_rerun, "start": self.start, "evaluations": self.evaluations,
                "generations": len(self.history), "history": self.history, "provenance": provenance}


def _write_json(path: Path, doc: dict) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
    tmp.replace(path)


def state_path(out: Path) -> Path:
    """Where the optimiser's own state is kept for `--resume` (next to the JSON)."""
    return out.with_suffix(".cma.pkl")


def _resume(out: Path, space: ParamSpace) -> tuple[cma.CMAEvolutionStrategy, TuneState]:
    try:
        doc = json.loads(out.read_text())
        es = pickle.loads(state_path(out).read_bytes())
        state = TuneState(doc["controller"], doc["best_params"], doc["best"], doc["start"], doc["history"],
                          doc["evaluations"])
    except (OSError, ValueError, KeyError, pickle.UnpicklingError) as exc:
        raise GripperError(f"cannot resume from {out} and {state_path(out)}: {exc}; start again without --resume") \
            from exc
    if state.controller != space.controller:
        raise GripperError(f"{out} tunes {state.controller}, not {space.controller}")
    return es, state


def run_cma(space: ParamSpace, chunks: Chunks, budget: int, out: Path, hi_p95_n: float, provenance: dict,
            resume: bool = False, popsize: int | None = None, seed: int = 0,
            on_generation: Callable[[TuneState], None] | None = None, drop_weight: float = 1.0,
            above_hi_per_n: float | None = None, runner: Runner | None = None) -> TuneState:
    """Tune `space` on `chunks` until `budget` evaluations (parameter sets run) are spent or CMA-ES
    stops; the start point is the controller's current parameters. After each generation the
    best-so-far goes to `out` (JSON) and the optimiser's state to `state_path(out)`. A
    KeyboardInterrupt stops the loop with both files up to date from the last full generation. At the
    end the best set is run again alone (`best_rerun`: the figures to quote). `drop_weight`: a
    drop counts this many failures in the objective, `above_hi_per_n` weighs each N of p95
    overshoot above HI's (`tuning.Scores.objective`). `runner`: where each generation's chunks
    run (`tuning.evaluate`; default here, `tuning.engine_runner` on the engine: the same scores)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if resume:
        es, state = _resume(out, space)
    else:
        start = space.defaults()
        opts = {"bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "tolfun": 1e-5}
        if popsize:
            opts["popsize"] = popsize
        es = cma.CMAEvolutionStrategy(space.to_unit(start), SIGMA0, opts)
        first = evaluate(chunks, space.controller, [start], runner).summary(0, hi_p95_n, drop_weight, above_hi_per_n)
        state = TuneState(space.controller, start, first, first, evaluations=1)
    t0 = time.perf_counter()
    while state.evaluations < budget and not es.stop():
        xs = es.ask()
        sets = [space.to_params(x) for x in xs]
        scores = evaluate(chunks, space.controller, sets, runner)
        j = scores.objective(hi_p95_n, drop_weight, above_hi_per_n)
        es.tell(xs, [float(v) for v in j])
        state.evaluations += len(sets)
        i = int(np.argmin(j))
        if j[i] < state.best["objective"]:
            state.best_params, state.best = sets[i], scores.summary(i, hi_p95_n, drop_weight, above_hi_per_n)
        state.history.append({"generation": len(state.history) + 1, "evaluations": state.evaluations,
                              "objective_min": float(j[i]), "objective_median": float(np.median(j)),
                              "best_objective": state.best["objective"], "sigma": float(es.sigma),
                              "wall_s": round(time.perf_counter() - t0, 1)})
        _write_json(out, state.to_json(provenance))
        state_path(out).write_bytes(es.pickle_dumps())
        if on_generation:
            on_generation(state)
    # Inside a generation each set sees its own sensor-noise draw (the plant draws noise per batch
    # position), so the best's figures are re-run alone, with the chunks' own noise, at the end.
    rerun = evaluate(chunks, space.controller, [state.best_params], runner)
    state.best_rerun = rerun.summary(0, hi_p95_n, drop_weight, above_hi_per_n)
    _write_json(out, state.to_json(provenance))
    return state
