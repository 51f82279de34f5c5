"""The truncated Green's function of one kernel width (Dean et al. 2018, §3.2, Eq. 3): :class:`GreensBasis`,
eigenpairs and degrees, whose rows cost ``O(F N)`` each.  The choices it makes (eigenvectors, null space,
self term) are stated in the docstring of :mod:`.greens`."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["GreensBasis"]

_COEF_TOL = 1e-10      # spectral weights below this are rounding noise of lambda = 1


@dataclass(frozen=True, eq=False)
class GreensBasis:
    """Truncated eigenbasis of the pose Laplacian for one sigma: Green's rows in ``O(F N)`` each.

    Attributes
    ----------
    eigenvalues : ndarray, shape (N,)
        Non-null eigenvalues ``lambda_k`` of ``L``, ascending.
    eigenvectors : ndarray, shape (F, N)
        ``psi_k = D^-1/2 phi_k`` (random walk) or ``phi_k`` (symmetric), one column per eigenvalue.
    degrees : ndarray, shape (F,)
        Kernel row sums ``r``.
    sigma : float
        Kernel width (pose-vector units, i.e. log-map radians / 2 when weights are 1).
    self_term : bool
        Spectral weight ``1/lambda`` (Eq. 3 as printed) when True, ``1/lambda - 1`` when False.
    normalization : str
        ``"random_walk"`` or ``"symmetric"``.
    method : str
        ``"dense"`` or ``"sparse"``.
    null_dim : int
        Number of null eigenvalues left out (connected components of the kernel graph), or -1 when the
        sparse solver could not tell.
    """

    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    degrees: np.ndarray
    sigma: float
    self_term: bool = False
    normalization: str = "random_walk"
    method: str = "dense"
    null_dim: int = 1
    _coef: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        lam = np.asarray(self.eigenvalues, dtype=float)
        coef = 1.0 / lam if self.self_term else 1.0 / lam - 1.0
        # lambda = 1 to rounding (e.g. every pose of a static clip alike) carries no weight: make it exactly 0
        coef[np.abs(coef) < _COEF_TOL] = 0.0
        object.__setattr__(self, "_coef", coef)

    @property
    def num_frames(self) -> int:
        return int(self.eigenvectors.shape[0])

    @property
    def num_eigs(self) -> int:
        return int(self.eigenvectors.shape[1])

    def _frames(self, frames) -> np.ndarray:
        f = np.asarray(frames)
        if f.dtype.kind not in "iu" or f.ndim > 1:
            raise ValueError(f"frame must be an integer frame index, got {frames!r}")
        if np.any(f < 0) or np.any(f >= self.num_frames):
            raise ValueError(f"frame must be in [0, {self.num_frames}), got {frames!r}")
        return f

    def row(self, frame: int) -> np.ndarray:
        """Green's row ``G(p_frame, p_j)`` for all ``j``, shape (F,): one ``(F, N) @ (N,)`` product."""
        f = self._frames(frame)
        if f.ndim:
            raise ValueError(f"frame must be one integer frame index, got {frame!r}")
        i = int(f)
        return self.eigenvectors @ (self.eigenvectors[i] * self._coef)

    def rows(self, frames) -> np.ndarray:
        """Green's rows for several frames, shape (E, F)."""
        f = self._frames(np.atleast_1d(np.asarray(frames)))
        return (self.eigenvectors[f] * self._coef) @ self.eigenvectors.T

    def matrix(self) -> np.ndarray:
        """The whole ``(F, F)`` matrix ``P`` of §3.2 (memory ``O(F^2)``: small clips and tests only)."""
        return (self.eigenvectors * self._coef) @ self.eigenvectors.T

