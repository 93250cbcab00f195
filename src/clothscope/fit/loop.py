"""The optimisation loop every stage shares: render, loss, backward, step, clamp, update.

It never lets a non-finite number through: a non-finite or climbing loss, or a
non-finite parameter, restores the best parameters so far, halves the step and
records a warning. A plateau rule stops early.

Which variables it returns is a choice (``LoopSettings.keep``). ``"best"``, the
lowest loss seen, suits short descents. But each loss is one noisy render, and
its expectation is the squared error *plus the render's variance*; a sharp
specular lobe has more variance at a few samples per pixel than a broad one,
so picking the lowest noisy loss favours rough lobes (on a photo rendered by the
fit model itself, "best" returned roughness 0.43 for a true 0.22 while the
iterates went on down to 0.36). ``"last"`` returns the final iterate: Adam's
steps use gradients from decorrelated samples (``seed_grad``), which carry no
such bias.
"""
from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np

Variables = dict[str, np.ndarray]


@dataclass(frozen=True)
class LoopSettings:
    """Iterations, step size and stopping rule of one optimisation."""

    iterations: int
    learning_rate: float
    patience: int = 0  # 0: no plateau rule
    min_improvement: float = 1e-3  # relative loss drop that counts as progress
    max_restarts: int = 4
    climb_factor: float = 3.0  # loss above this times the best counts as a blow-up
    keep: str = "best"  # "best": lowest noisy loss; "last": the final iterate (see the module docstring)
    uniform: bool = False  # Uniform Adam (Nicolet et al. 2021): one second moment, the largest, per variable
    rates: dict[str, float] = field(default_factory=dict)  # variable -> its own learning rate, halved on restarts too
    sample_seed: int = 0  # the config's fit.sample_seed: iteration i renders with render_seed(sample_seed, i)
    seed_cycle: int = 0  # > 0: iteration i renders with the seed of iteration i mod seed_cycle (the same rays again)

    def __post_init__(self) -> None:
        if self.keep not in ("best", "last"):
            raise ValueError(f"keep must be 'best' or 'last', got {self.keep!r}")
        if self.iterations < 0:
            raise ValueError(f"iterations must be >= 0, got {self.iterations}")
        if not self.learning_rate > 0:
            raise ValueError(f"learning_rate must be > 0, got {self.learning_rate}")
        if self.seed_cycle < 0:
            raise ValueError(f"seed_cycle must be >= 0, got {self.seed_cycle}")


@dataclass
class LoopResult:
    """The variables returned (``best``: lowest loss, or the last iterate), the loss curve and any warnings."""

    best: Variables
    best_loss: float
    curve: list[dict[str, float]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    stopped: str = "iterations"
    seconds: float = 0.0


def _finite(values: Variables) -> bool:
    return all(np.all(np.isfinite(v)) for v in values.values())


def adam(mi: Any, values: Variables, settings: LoopSettings, lr: float) -> Any:
    """Adam over ``values`` at step ``lr``; each variable of ``settings.rates`` at its rate, scaled alike."""
    scale = lr / settings.learning_rate
    opt = mi.ad.Adam(lr=lr, uniform=settings.uniform, params={k: mi.Float(v) for k, v in values.items()})
    opt.set_learning_rate({k: rate * scale for k, rate in settings.rates.items() if k in values})
    return opt


def render_seed(sample_seed: int, iteration: int) -> int:
    """The render seed of ``iteration`` under the config's ``fit.sample_seed``; different ``sample_seed`` never meet.

    Iterations stay below 5000 (the schema's bound), and :func:`render` takes the
    gradient pass's seed 100 003 above the primal one, so a block of a million
    seeds per ``sample_seed`` keeps every run's primal and gradient seeds apart.
    """
    return sample_seed * 1_000_000 + iteration


def optimise(mi: Any, initial: Variables, loss_fn: Callable[[dict[str, Any], int], Any], settings: LoopSettings,
             log: logging.Logger, name: str) -> LoopResult:
    """Minimise ``loss_fn(variables, seed)`` with Adam from ``initial``; ``seed`` is the iteration's render seed.

    Parameters
    ----------
    mi : the Mitsuba module (variant set).
    initial : name -> flat float32 array of each optimised variable.
    loss_fn : builds the scene from the optimiser's variables (a dict-like of
        differentiable arrays), renders with the given seed and returns a scalar
        differentiable loss.
    """
    lr = settings.learning_rate
    opt = adam(mi, initial, settings, lr)
    result = LoopResult(best={k: v.copy() for k, v in initial.items()}, best_loss=math.inf)
    restarts, since_progress, started = 0, 0, time.perf_counter()
    for it in range(settings.iterations):
        loss = loss_fn(opt, render_seed(settings.sample_seed, it % settings.seed_cycle if settings.seed_cycle else it))
        value = float(loss.array[0] if hasattr(loss, "array") else loss[0])
        blow_up = not math.isfinite(value) or (math.isfinite(result.best_loss) and value > settings.climb_factor * result.best_loss)
        if blow_up:
            restarts += 1
            result.warnings.append(f"{name}: iteration {it}: loss {value:.3g} (best {result.best_loss:.3g}); restarting with step {lr / 2:.3g}")
            log.warning(result.warnings[-1])
            if restarts > settings.max_restarts:
                result.stopped = "gave up after restarts"
                break
            lr /= 2
            opt = adam(mi, result.best, settings, lr)
            continue
        if value < result.best_loss * (1 - settings.min_improvement):
            since_progress = 0
        else:
            since_progress += 1
        if value < result.best_loss:
            current = {k: np.array(opt[k], dtype=np.float32) for k in initial}
            if _finite(current):
                result.best, result.best_loss = current, value
        result.curve.append({"iteration": it, "loss": value, "learning_rate": lr, "seconds": time.perf_counter() - started})
        if settings.patience and since_progress >= settings.patience:
            result.stopped = f"plateau: no {settings.min_improvement:.1%} improvement in {settings.patience} iterations"
            break
        dr.backward(loss, flags=dr.ADFlag.Default | dr.ADFlag.AllowNoGrad)
        opt.step()
        for key in initial:  # a non-finite gradient must not poison the parameters
            if not dr.all(dr.isfinite(opt[key]), axis=None):
                opt[key] = mi.Float(result.best[key])
                result.warnings.append(f"{name}: iteration {it}: non-finite {key} after the step; reset to best")
                log.warning(result.warnings[-1])
    result.seconds = time.perf_counter() - started
    if settings.keep == "last" and result.curve and not result.stopped.startswith("gave up"):
        last = {k: np.array(opt[k], dtype=np.float32) for k in initial}
        if _finite(last):
            result.best, result.best_loss = last, result.curve[-1]["loss"]
    if not math.isfinite(result.best_loss):
        result.warnings.append(f"{name}: no finite loss was ever reached; keeping the initial values")
        result.best = {k: v.copy() for k, v in initial.items()}
        result.best_loss = 0.0
    log.info("%s: %d iterations, best loss %.4g, stopped: %s, %.1f s", name, len(result.curve), result.best_loss,
             result.stopped, result.seconds)
    return result


# --- differentiable pieces every stage's loss uses -----------------------------------------

def render(mi: ModuleType, scene: Any, params: Any, spp: int, seed: int, spp_grad: int = 0) -> Any:
    """Render with a fresh seed per iteration (the primal and gradient noise decorrelate).

    ``spp`` samples per pixel go into the image the loss compares with the photo,
    ``spp_grad`` into the gradient pass (0: the same as ``spp``).
    """
    return mi.render(scene, params, spp=spp, spp_grad=spp_grad, seed=seed, seed_grad=seed + 100_003)


def sigmoid(x: Any) -> Any:
    """The logistic function on Dr.Jit arrays: a latent in R onto (0, 1)."""
    return 1.0 / (1.0 + dr.exp(-x))


def logit(p: np.ndarray | float) -> np.ndarray:
    """The inverse of :func:`sigmoid` (NumPy), with ``p`` clipped to [1e-4, 1 - 1e-4] so it stays finite."""
    p = np.clip(np.asarray(p, dtype=np.float32), 1e-4, 1 - 1e-4)
    return np.log(p / (1 - p)).astype(np.float32)
