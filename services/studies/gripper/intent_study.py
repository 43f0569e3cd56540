"""Can the wrist tell a taking receiver from the others early enough? Collect the contact-onset
features of `services.studies.gripper.intent_features` on benchmark episodes (closed loop with SG, the
law the gate sits on), fit a logistic model of P(taking) on the tuning seed (scipy, L2-penalised
log-loss), and measure its accuracy on held-out seeds, per receiver kind.

Labels: taking = the three taking kinds (lift first, pull first, drag); not taking = dropping,
hesitating, bumping. Episodes without a contact onset (a hesitating receiver that never loads
the wrist past the threshold) are "not taking" and undecided: the gate never sees them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from robot_sim.contact.episode import run_vectorised
from services.studies.gripper.intent_features import FEATURE_NAMES, IntentFeatures, IntentModel
from services.gripper.controllers.registry import make_controller
from services.gripper.errors import GripperError
from services.studies.gripper.episodes import RECEIVER_KINDS
from services.studies.gripper.tuning import Chunks

__all__ = ["FeatureSet", "accuracy_table", "collect", "fit"]

#: L2 penalty of the standardised weights (per episode).
L2 = 1e-3


class _Recorder:
    """A controller that runs another and feeds every sample to an `IntentFeatures`."""

    def __init__(self, inner) -> None:
        self.inner, self.period_s = inner, inner.period_s

    def reset(self, n_episodes: int = 1) -> None:
        self.inner.reset(n_episodes)
        self.features = IntentFeatures(n_episodes)

    def step(self, sample):
        self.features.update(sample)
        return self.inner.step(sample)


@dataclass(frozen=True)
class FeatureSet:
    """Features (n, d; NaN where not captured), decided (bool), taking (bool label), receiver kind
    code (`RECEIVER_KINDS` order), gripper class name per episode, onset time after the receiver's
    grasp start (s)."""

    x: np.ndarray
    decided: np.ndarray
    taking: np.ndarray
    kind: np.ndarray
    gripper: np.ndarray
    onset_after_grasp_s: np.ndarray


def collect(chunks: Chunks, controller: str = "SG") -> FeatureSet:
    """Run `controller` on `chunks` and capture every episode's intent features."""
    parts = []
    for chunk, noise in chunks:
        rec = _Recorder(make_controller(controller, period_s=chunk.control_period_s))
        run_vectorised(chunk.config, chunk.receivers, rec, seed=noise)
        f = rec.features
        kind = chunk.kind if chunk.kind is not None else np.where(chunk.behaviour == 0, 0, chunk.behaviour)
        parts.append((f.values.copy(), f.decided.copy(), chunk.behaviour == 0, np.asarray(kind),
                      np.full(chunk.behaviour.size, chunk.gripper), f.onset_s - chunk.grasp_start_s))
    return FeatureSet(*(np.concatenate([p[i] for p in parts]) for i in range(6)))


def fit(data: FeatureSet, provenance: dict | None = None) -> IntentModel:
    """Logistic regression of `taking` on the decided episodes' features (standardised; L-BFGS on
    the mean log-loss + `L2` · |w|²)."""
    x, y = data.x[data.decided], data.taking[data.decided].astype(float)
    if len(np.unique(y)) < 2:
        raise GripperError("intent fit: need both taking and non-taking episodes with a contact onset")
    x = np.nan_to_num(x)
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale = np.where(scale > 1e-9, scale, 1.0)
    z = (x - mean) / scale

    def loss(theta: np.ndarray) -> tuple[float, np.ndarray]:
        logits = theta[0] + z @ theta[1:]
        p = 1.0 / (1.0 + np.exp(-np.clip(logits, -50, 50)))
        nll = np.mean(np.logaddexp(0.0, logits) - y * logits) + L2 * np.sum(theta[1:] ** 2)
        grad_logit = (p - y) / y.size
        grad = np.concatenate([[grad_logit.sum()], z.T @ grad_logit + 2 * L2 * theta[1:]])
        return float(nll), grad

    res = optimize.minimize(loss, np.zeros(z.shape[1] + 1), jac=True, method="L-BFGS-B")
    if not res.success:
        raise GripperError(f"intent fit did not converge: {res.message}")
    return IntentModel(tuple(map(float, res.x[1:])), float(res.x[0]), tuple(map(float, mean)),
                       tuple(map(float, scale)), 0.5, provenance)


def accuracy_table(model: IntentModel, data: FeatureSet) -> list[dict]:
    """Per receiver kind and overall: episodes, decided, share classified taking, accuracy (over the
    decided episodes; undecided non-taking episodes count as correct, as the gate never acts on
    them), and the median onset after the grasp start (s)."""
    pred = np.zeros(data.taking.size, dtype=bool)
    pred[data.decided] = model.probability(data.x[data.decided]) >= model.threshold
    correct = np.where(data.decided, pred == data.taking, ~data.taking)
    rows = []
    groups = [(RECEIVER_KINDS[k], data.kind == k) for k in np.unique(data.kind)] + [("all", np.ones_like(pred))]
    for label, m in groups:
        onset = data.onset_after_grasp_s[m & data.decided]
        rows.append({"kind": label, "episodes": int(m.sum()), "decided": int((m & data.decided).sum()),
                     "classified_taking": float(pred[m].mean()), "accuracy": float(correct[m].mean()),
                     "onset_after_grasp_median_s": float(np.median(onset)) if onset.size else float("nan")})
    return rows


def coefficients(model: IntentModel) -> dict[str, float]:
    """Standardised weight per feature (positive: more of it means more likely taking)."""
    return dict(zip(FEATURE_NAMES, model.weights))
