"""Large Steps coordinates of a height map on its texel grid, solved by a cosine transform.

The normal-map stage can step the differential coordinates ``u = (I + lambda L) h``
of its height map ``h`` instead of the heights (Nicolet et al. 2021, the method
the geometry stage uses for its vertices). ``L`` is the 4-neighbour graph
Laplacian of the texel grid, a border texel having only the neighbours it has
(the Laplacian of :func:`.normals.curvature`). That matrix is diagonal in the
type-II discrete cosine basis, so ``h = (I + lambda L)^-1 u`` is two transforms
and a division, with no factorisation, and the matrix being symmetric, the same
solve carries the gradient back.
"""
from __future__ import annotations

from typing import Any

import drjit as dr
import numpy as np
from scipy.fft import dctn, idctn


def laplacian_eigenvalues(size: int) -> np.ndarray:
    """Eigenvalues ``2 - 2 cos(pi k / size)`` of the graph Laplacian of a path of ``size`` nodes, in cosine order."""
    return 2.0 - 2.0 * np.cos(np.pi * np.arange(size) / size)


class HeightSteps:
    """The system ``I + lambda L`` of a ``size`` x ``size`` texel grid.

    Parameters
    ----------
    size : texels per side.
    lambda_ : weight of the Laplacian (> 0); larger values diffuse each step over more texels.
    """

    def __init__(self, size: int, lambda_: float) -> None:
        if not lambda_ > 0:
            raise ValueError(f"the Large Steps lambda must be > 0, got {lambda_}")
        mu = laplacian_eigenvalues(size)
        self.size = size
        self.spectrum = 1.0 + lambda_ * (mu[:, None] + mu[None, :])

    def solve(self, u: np.ndarray) -> np.ndarray:
        """Flat heights ``(I + lambda L)^-1 u`` of flat differential coordinates ``u``."""
        return self._in_cosine_basis(u, 1.0 / self.spectrum)

    def to_differential(self, height: np.ndarray) -> np.ndarray:
        """Flat differential coordinates ``(I + lambda L) h`` of flat heights ``h``."""
        return self._in_cosine_basis(height, self.spectrum)

    def _in_cosine_basis(self, values: np.ndarray, gains: np.ndarray) -> np.ndarray:
        """Flat ``values`` with each cosine coefficient multiplied by its gain."""
        grid = np.asarray(values, dtype=np.float64).reshape(self.size, self.size)
        return idctn(dctn(grid, norm="ortho") * gains, norm="ortho").ravel()

    def from_differential(self, u: Any) -> Any:
        """Differentiable heights of a Dr.Jit array of differential coordinates."""
        return dr.custom(_Solve, self, u)


class _Solve(dr.CustomOp):
    """Dr.Jit operation ``h = (I + lambda L)^-1 u``; its own adjoint, since the matrix is symmetric."""

    def eval(self, steps: HeightSteps, u: Any) -> Any:
        self.steps, self.kind = steps, type(u)
        return self._solved(u)

    def forward(self) -> None:
        self.set_grad_out(self._solved(self.grad_in("u")))

    def backward(self) -> None:
        self.set_grad_in("u", self._solved(self.grad_out()))

    def name(self) -> str:
        return "Large Steps solve"

    def _solved(self, values: Any) -> Any:
        return self.kind(self.steps.solve(np.array(values)).astype(np.float32))
