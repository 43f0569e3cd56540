"""What the wrist can tell about the receiver's intent, early: the contact-onset features and a
logistic model that turns them into P(the receiver is taking the object).

Features (`IntentFeatures`, online and vectorised over episodes; gripper frame, x toward the
receiver, y down): W0 = F_sy of the first sample; the contact onset is the first sample where
|F − F(0)| > f_on = 0.5 N + 0.1 W0; then, at each lag of `LAGS_S` after the onset, the change of
the wrist force since t = 0 in units of the weight, (ΔF_x/W0, ΔF_y/W0), and the largest optical
slip speed seen since the onset (m/s, 0 where the sensor does not see the object). The decision
is taken at the last lag (`decision_s`). Why these: a receiver who lifts unloads the wrist
(ΔF_y < 0) with the grasp, before its pull builds; a hooking (dropping) receiver pulls along its
pull direction only; a bump pushes toward the robot (ΔF_x < 0); a hesitating one barely loads
the wrist. Everything here is what a controller could compute online, from the samples it
gets. The study that fits the model and measures its held-out accuracy:
`services.studies.gripper.intent_study` (`handover-study intent`), docs/gripper.md "Intent".
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from handover_model.grip import SensorSample
from services.gripper.errors import GripperError

__all__ = ["FEATURE_NAMES", "LAGS_S", "IntentFeatures", "IntentModel"]

#: Lags after the contact onset at which the wrist force change is captured, s (the decision at the last).
LAGS_S = (0.02, 0.05, 0.1)
#: Onset threshold: |ΔF| > ONSET_N + ONSET_PER_WEIGHT · W0.
ONSET_N, ONSET_PER_WEIGHT = 0.5, 0.1
FEATURE_NAMES = tuple([f"{axis}_{int(1000 * lag)}ms" for lag in LAGS_S for axis in ("dfx_w", "dfy_w")]
                      + ["slip_max_m_s"])


class IntentFeatures:
    """Online feature capture for a batch of episodes (module docstring). After each `update`,
    `decided` marks the episodes whose features are complete and `values` holds them
    (shape (n, len(FEATURE_NAMES)), NaN until captured)."""

    def __init__(self, n_episodes: int) -> None:
        self.n = int(n_episodes)
        self.weight0: np.ndarray | None = None
        self.f0x = np.zeros(self.n)
        self.onset_s = np.full(self.n, np.nan)
        self.values = np.full((self.n, len(FEATURE_NAMES)), np.nan)
        self.slip_max = np.zeros(self.n)
        self.decided = np.zeros(self.n, dtype=bool)

    def update(self, sample: SensorSample) -> None:
        fx = np.broadcast_to(np.asarray(sample.force_x_n, dtype=float), (self.n,))
        fy = np.broadcast_to(np.asarray(sample.force_y_n, dtype=float), (self.n,))
        t = float(sample.time_s)
        if self.weight0 is None:
            self.weight0, self.f0x = np.maximum(fy.copy(), 1e-3), fx.copy()
            return
        dfx, dfy = (fx - self.f0x) / self.weight0, (fy - self.weight0) / self.weight0
        started = np.isfinite(self.onset_s)
        new = ~started & (np.hypot(dfx, dfy) * self.weight0 > ONSET_N + ONSET_PER_WEIGHT * self.weight0)
        self.onset_s = np.where(new, t, self.onset_s)
        started |= new
        speed = np.hypot(np.asarray(sample.slip_velocity_x_m_s, dtype=float),
                         np.asarray(sample.slip_velocity_y_m_s, dtype=float))
        speed = np.where(np.asarray(sample.optical_valid, dtype=bool), speed, 0.0)
        self.slip_max = np.where(started, np.maximum(self.slip_max, speed), 0.0)
        since = t - self.onset_s
        for k, lag in enumerate(LAGS_S):
            take = started & (since >= lag - 1e-9) & np.isnan(self.values[:, 2 * k])
            self.values[take, 2 * k] = dfx[take]
            self.values[take, 2 * k + 1] = dfy[take]
        now = started & ~self.decided & (since >= LAGS_S[-1] - 1e-9)
        self.values[now, -1] = self.slip_max[now]
        self.decided |= now


@dataclass(frozen=True)
class IntentModel:
    """Logistic model P(taking | features) = σ(b + Σ w_i (x_i − mean_i)/scale_i), and the
    decision threshold on it. `provenance` says how it was fitted and its held-out accuracy."""

    weights: tuple[float, ...]
    bias: float
    mean: tuple[float, ...]
    scale: tuple[float, ...]
    threshold: float = 0.5
    provenance: dict | None = None

    def __post_init__(self) -> None:
        d = len(FEATURE_NAMES)
        if not (len(self.weights) == len(self.mean) == len(self.scale) == d):
            raise GripperError(f"intent model: need {d} weights, means and scales ({', '.join(FEATURE_NAMES)})")
        values = [*self.weights, self.bias, *self.mean, *self.scale, self.threshold]
        if not all(math.isfinite(v) for v in values) or min(self.scale) <= 0 or not 0 < self.threshold < 1:
            raise GripperError("intent model: weights must be finite, scales > 0 and the threshold in (0, 1)")

    def probability(self, features: np.ndarray) -> np.ndarray:
        """P(taking) per row of `features` (shape (n, d)); NaN features count as 0 change."""
        x = (np.nan_to_num(np.asarray(features, dtype=float)) - np.array(self.mean)) / np.array(self.scale)
        z = self.bias + x @ np.array(self.weights)
        return 1.0 / (1.0 + np.exp(-np.clip(z, -50.0, 50.0)))

    def save(self, path: Path) -> Path:
        doc = {"features": list(FEATURE_NAMES), "weights": list(self.weights), "bias": self.bias,
               "mean": list(self.mean), "scale": list(self.scale), "threshold": self.threshold,
               "provenance": self.provenance or {}}
        Path(path).write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
        return Path(path)

    @staticmethod
    def load(path: Path) -> "IntentModel":
        try:
            doc = json.loads(Path(path).read_text())
            if doc["features"] != list(FEATURE_NAMES):
                raise ValueError(f"features {doc['features']} are not this version's {list(FEATURE_NAMES)}")
            return IntentModel(tuple(doc["weights"]), float(doc["bias"]), tuple(doc["mean"]), tuple(doc["scale"]),
                               float(doc["threshold"]), doc.get("provenance"))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise GripperError(f"cannot read the intent model {path}: {exc} "
                               "(write one with `handover-study intent --model-out FILE`)") from exc
