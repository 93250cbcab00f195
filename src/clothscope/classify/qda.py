"""The classifier: a standardised, shrunk QDA whose class covariance eigenvalues are floored."""
from __future__ import annotations

import math
import warnings
from numbers import Real
from typing import Any

import numpy as np
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis, QuadraticDiscriminantAnalysis
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval

#: Smallest per-class variance along any principal axis, in units of the
#: (training-set) standardised features. Keeps a class whose images agree
#: exactly on some feature from getting an infinitely narrow Gaussian.
VAR_FLOOR = 1e-3


#: Feature spaces QDA can be fitted in: the standardised features as they are
#: (the paper's), or their discriminant subspace (see :func:`make_qda`).
SUBSPACES = ("none", "discriminant")


class FlooredQDA(QuadraticDiscriminantAnalysis):
    """QDA whose per-class covariance eigenvalues are at least ``var_floor``.

    Identical to scikit-learn's ``QuadraticDiscriminantAnalysis`` with
    ``solver="eigen"`` (shrinkage, priors and all), except that after the
    shrunk class covariance is decomposed its eigenvalues are clipped from
    below. Without the floor, Ledoit-Wolf shrinkage of a 2-image class is
    ~0 (rank-1 covariance) and a class constant in every feature has a zero
    covariance; both make ``fit`` raise or the posteriors NaN.

    Parameters
    ----------
    var_floor
        Lower bound of each eigenvalue; must exceed ``tol``.
    """

    _parameter_constraints: dict = {
        **QuadraticDiscriminantAnalysis._parameter_constraints,
        "var_floor": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        *,
        solver: str = "eigen",
        shrinkage: str | float | None = None,
        priors: Any = None,
        reg_param: float = 0.0,
        store_covariance: bool = False,
        tol: float = 1.0e-4,
        covariance_estimator: Any = None,
        var_floor: float = VAR_FLOOR,
    ) -> None:
        super().__init__(
            solver=solver,
            shrinkage=shrinkage,
            priors=priors,
            reg_param=reg_param,
            store_covariance=store_covariance,
            tol=tol,
            covariance_estimator=covariance_estimator,
        )
        self.var_floor = var_floor

    def fit(self, X: Any, y: Any) -> FlooredQDA:
        """Fit as QDA with ``solver="eigen"``; see the class docstring."""
        if self.solver != "eigen":
            raise ValueError(f"FlooredQDA needs solver='eigen', got {self.solver!r}")
        if not self.var_floor > self.tol:
            raise ValueError(f"var_floor ({self.var_floor}) must exceed tol ({self.tol})")
        return super().fit(X, y)

    def _solve_eigen(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        scaling, rotation, _ = super()._solve_eigen(X)
        scaling = np.maximum(np.nan_to_num(scaling, nan=0.0), self.var_floor)
        cov = (rotation * scaling) @ rotation.T
        return scaling, rotation, cov


def check_reg(reg: float | str) -> float | str:
    if isinstance(reg, str):
        if reg != "auto":
            raise ValueError(f"reg must be 'auto' (Ledoit-Wolf) or a float in [0, 1], got {reg!r}")
        return reg
    if isinstance(reg, bool) or not isinstance(reg, Real) or not (0.0 <= float(reg) <= 1.0):
        raise ValueError(f"reg must be 'auto' (Ledoit-Wolf) or a float in [0, 1], got {reg!r}")
    return float(reg)


def check_subspace(subspace: str) -> str:
    if subspace not in SUBSPACES:
        raise ValueError(f"subspace must be one of {', '.join(SUBSPACES)}, got {subspace!r}")
    return subspace


def make_qda(reg: float | str = "auto", *, var_floor: float = VAR_FLOOR, subspace: str = "none") -> Pipeline:
    """The classifier: standardise features, optionally project them, then shrunk QDA with floored class covariances.

    Parameters
    ----------
    reg
        Covariance shrinkage: ``"auto"`` (Ledoit-Wolf) or a float in [0, 1].
    var_floor
        Lower bound of each class-covariance eigenvalue, in standardised units.
    subspace
        ``"none"``: QDA on the standardised features (the paper's classifier).
        ``"discriminant"``: QDA on the at most ``n_classes - 1`` Fisher
        discriminant directions of the training images (shrunk LDA,
        Ledoit-Wolf), fitted inside the pipeline so that a LOOCV fold never
        sees its held-out image. With a handful of images per class and tens
        of features, each class covariance is then estimated in a few
        dimensions instead of tens.

    Returns
    -------
    sklearn.pipeline.Pipeline
        Steps ``scale`` (StandardScaler), ``project`` (with
        ``subspace="discriminant"``) and ``qda`` (:class:`FlooredQDA`,
        ``solver="eigen"``, ``shrinkage=reg``, ``priors=None``: class
        proportions of the training data).
    """
    reg = check_reg(reg)
    subspace = check_subspace(subspace)
    if not (math.isfinite(var_floor) and var_floor > 0):
        raise ValueError(f"var_floor must be a finite number > 0, got {var_floor}")
    qda = FlooredQDA(solver="eigen", shrinkage=reg, priors=None, var_floor=var_floor, tol=min(1e-4, var_floor / 2))
    steps: list[tuple[str, Any]] = [("scale", StandardScaler())]
    if subspace == "discriminant":
        steps.append(("project", LinearDiscriminantAnalysis(solver="eigen", shrinkage="auto")))
    return Pipeline([*steps, ("qda", qda)])


def fit_qda(reg: float | str, X: np.ndarray, y: np.ndarray, notes: list[str], subspace: str = "none") -> Pipeline:
    """Fit :func:`make_qda`; warnings become notes (each once)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = make_qda(reg, subspace=subspace).fit(X, y)
    for w in caught:
        message = f"scikit-learn warning: {w.message}"
        if message not in notes:
            notes.append(message)
    return model


def posteriors(pipeline: Pipeline, X: np.ndarray, ids: list[str]) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        proba = pipeline.predict_proba(X)
    return check_posteriors(proba, ids)


def check_posteriors(proba: np.ndarray, ids: list[str]) -> np.ndarray:
    bad = ~np.isfinite(proba).all(axis=1)
    if bad.any():
        raise ValueError(f"posteriors are not finite for image(s) {', '.join(np.asarray(ids)[bad])}: feature values too extreme")
    return proba
