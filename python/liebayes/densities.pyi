"""Probability densities on the circle, the sphere S², unit quaternions and SO(3).

Points are ``float64`` arrays whose trailing dimensions are one point and whose leading dimensions
are any batch shape: an angle ``()`` (radians), a unit vector ``(3,)``, a unit quaternion ``(4,)``
scalar first ``(w, x, y, z)``, a rotation matrix ``(3, 3)``. ``log_pdf`` returns one value per point
with the batch shape (a ``float`` for a single point). Every point is validated (finite, unit norm to
1e-9, orthonormal) and a failure raises ``ValueError`` naming its flat index.

``sample(n, rng)`` draws one integer ``rng.integers(0, 2**63)`` from the ``numpy.random.Generator``
``rng`` and seeds the library's ChaCha8 stream with it, so the same generator state gives the same
draws (and the generator advances by one draw). ``rng`` of another type raises ``TypeError``. One
call returns at most 2^28 values (n times the values of a point); more raises ``ValueError``. A
refused call draws nothing from ``rng``.

A ``float`` argument takes a Python or numpy integer or float, or a 0-d array of one; a bool, a
complex number, a string or an array of one element raises ``TypeError``. Every invalid argument
(NaN, wrong shape, out of range, non-unit mean) raises ``ValueError`` with the library's message.
``n`` is an ``int`` (or a numpy integer): a bool raises ``TypeError``, a negative or too large
value ``ValueError`` (never ``OverflowError``). A list holding a bool raises ``TypeError``.

The classes cannot be subclassed; their instances are immutable and can be shared by threads.
"""

from typing import Optional, Tuple, Union, final

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
FloatOrArray = Union[float, npt.NDArray[np.float64]]
Array = npt.NDArray[np.float64]

@final
class VonMises:
    """The von Mises distribution on the circle,
    ``p(θ) = exp(κ cos(θ − μ)) / (2π I₀(κ))`` with respect to dθ (total mass 2π).

    κ from 0 (the uniform distribution) to 1e300; the log density is accurate to a few ulp at any κ.
    """

    def __init__(self, mu: float, kappa: float) -> None:
        """Mean direction ``mu`` (radians, finite) and concentration ``kappa`` in [0, 1e300].

        Raises ``ValueError`` for NaN, infinite or negative values."""
    @staticmethod
    def from_natural(eta: ArrayLike) -> "VonMises":
        """From the natural parameter ``eta = κ (cos μ, sin μ)``, shape ``(2,)``."""
    @staticmethod
    def uniform() -> "VonMises":
        """The uniform distribution, ``1/(2π)``."""
    @staticmethod
    def fit(samples: ArrayLike, weights: Optional[ArrayLike] = None) -> "VonMises":
        """Maximum-likelihood fit to angles ``samples`` (any shape), with optional non-negative
        ``weights`` of the same shape: ``μ`` the weighted circular mean, ``κ = A⁻¹(R̄)``.

        Raises ``ValueError`` for no samples, non-finite angles, or bad weights."""
    def log_pdf(self, x: ArrayLike) -> FloatOrArray:
        """``ln p(θ)`` for angles ``x`` of any shape (radians)."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws, angles in (−π, π], shape ``(n,)``."""
    def product(self, other: "VonMises") -> Tuple["VonMises", float]:
        """The normalised product ``p q / ∫ p q`` (natural parameters add) and the log evidence
        ``ln ∫ p q dθ``."""
    def log_normaliser(self) -> float:
        """``ln Z = ln(2π I₀(κ))``."""
    def log_normaliser_gradient(self) -> Array:
        """``∂ ln Z/∂η = E[(cos θ, sin θ)] = A(κ)(cos μ, sin μ)``, shape ``(2,)``."""
    @property
    def natural(self) -> Array:
        """``η = κ (cos μ, sin μ)``, shape ``(2,)``."""
    @property
    def mean(self) -> Optional[float]:
        """The mean direction μ in (−π, π], ``None`` for κ = 0."""
    @property
    def concentration(self) -> float:
        """κ."""
    def mean_resultant_length(self) -> float:
        """``A(κ) = I₁(κ)/I₀(κ)``."""
    def circular_variance(self) -> float:
        """``1 − A(κ)``."""
    def entropy(self) -> float:
        """Differential entropy with respect to dθ."""
    def kl_divergence(self, other: "VonMises") -> float:
        """``KL(self ‖ other)``."""

@final
class VonMisesFisher:
    """The von Mises-Fisher distribution on S²,
    ``p(x) = κ/(4π sinh κ) exp(κ μ·x)`` with respect to the surface measure (total 4π).

    κ from 0 (uniform) to 1e300."""

    def __init__(self, mean: ArrayLike, kappa: float) -> None:
        """Unit mean direction ``mean`` (shape ``(3,)``, norm 1 to 1e-9) and ``kappa`` in [0, 1e300]."""
    @staticmethod
    def from_natural(eta: ArrayLike) -> "VonMisesFisher":
        """From ``eta = κ μ``, shape ``(3,)`` (η = 0 is the uniform distribution)."""
    @staticmethod
    def uniform() -> "VonMisesFisher":
        """The uniform distribution, ``1/(4π)``."""
    @staticmethod
    def fit(samples: ArrayLike, weights: Optional[ArrayLike] = None) -> "VonMisesFisher":
        """Maximum-likelihood fit to unit vectors ``samples`` (shape ``(n, 3)``) with optional
        non-negative ``weights`` (shape ``(n,)``): ``μ`` the direction of the weighted mean,
        ``κ = A₃⁻¹(|mean|)`` (``coth κ − 1/κ = |mean|``).

        Raises ``ValueError`` for non-unit samples, no samples, bad weights, or samples that all
        coincide (infinite concentration)."""
    def log_pdf(self, x: ArrayLike) -> FloatOrArray:
        """``ln p(x)`` for unit vectors of shape ``(3,)`` or ``(..., 3)``."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws (Wood's exact algorithm), shape ``(n, 3)``."""
    def product(self, other: "VonMisesFisher") -> Tuple["VonMisesFisher", float]:
        """The normalised product (natural parameters add) and ``ln ∫ p q dS``."""
    def log_normaliser(self) -> float:
        """``ln Z = ln(4π sinh κ / κ)``."""
    def log_normaliser_gradient(self) -> Array:
        """``∂ ln Z/∂η = E[x] = (coth κ − 1/κ) μ``, shape ``(3,)``."""
    @property
    def natural(self) -> Array:
        """``η = κ μ``, shape ``(3,)``."""
    @property
    def mean(self) -> Optional[Array]:
        """μ, shape ``(3,)``, ``None`` for κ = 0."""
    @property
    def concentration(self) -> float:
        """κ."""
    def first_moment(self) -> Array:
        """``E[x]``, shape ``(3,)``."""
    def entropy(self) -> float:
        """Differential entropy with respect to the surface measure."""
    def kl_divergence(self, other: "VonMisesFisher") -> float:
        """``KL(self ‖ other)``."""

@final
class Bingham:
    """The Bingham distribution on unit quaternions ``q = (w, x, y, z)``,
    ``p(q) = exp(qᵀ M q) / K(M)``, ``M = V diag(z) Vᵀ``, with respect to the uniform probability
    measure on S³ (so ``p(q) = p(−q)`` is also a density on SO(3) against its Haar measure).

    Eigenvalue spread ``max z − min z`` at most 1e12; only differences of eigenvalues matter."""

    def __init__(self, orientation: ArrayLike, eigenvalues: ArrayLike) -> None:
        """Orthogonal ``orientation`` V, shape ``(4, 4)`` (column k the eigenvector of eigenvalue k,
        to 1e-10), and ``eigenvalues`` z, shape ``(4,)``, in any order (sorted descending with
        their columns)."""
    @staticmethod
    def from_natural(m: ArrayLike) -> "Bingham":
        """From the symmetric parameter matrix ``M``, shape ``(4, 4)``."""
    @staticmethod
    def from_direction(measured: ArrayLike, reference: ArrayLike, sigma: float) -> "Bingham":
        """The likelihood of a body-frame ``measured`` direction of the world ``reference``
        direction with isotropic Gaussian noise ``sigma``, as a density of the orientation. Its
        spread is ``2/sigma²``, at most 1e12: ``sigma`` at least ``sqrt(2e-12)``, about 1.414e-6."""
    @staticmethod
    def uniform() -> "Bingham":
        """The uniform distribution on S³."""
    @staticmethod
    def fit(samples: ArrayLike, weights: Optional[ArrayLike] = None) -> "Bingham":
        """Maximum-likelihood fit to unit quaternions ``samples`` (shape ``(n, 4)``) with optional
        non-negative ``weights`` (shape ``(n,)``), from their weighted scatter matrix.

        Raises ``ValueError`` for non-unit samples, no samples, samples on a lower-dimensional
        sphere (infinite concentration) or a fitted spread beyond 1e12."""
    def log_pdf(self, q: ArrayLike) -> FloatOrArray:
        """``ln p(q)`` for unit quaternions of shape ``(4,)`` or ``(..., 4)``."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws (exact rejection sampling), shape ``(n, 4)``."""
    def product(self, other: "Bingham") -> Tuple["Bingham", float]:
        """The normalised product (``M₁ + M₂``) and ``ln ∫ p q``; ``ValueError`` when the
        product's spread exceeds 1e12."""
    def log_normaliser(self) -> float:
        """``ln K(z)`` against the uniform probability measure on S³."""
    def log_normaliser_surface(self) -> float:
        """``ln K`` against the surface measure of S³ (``log_normaliser() + ln 2π²``)."""
    def log_normaliser_gradient(self) -> Array:
        """``∂ ln K/∂zₖ = E[(vₖ·q)²]`` in the order of ``eigenvalues``, shape ``(4,)``."""
    @property
    def eigenvalues(self) -> Array:
        """z, descending, shape ``(4,)``."""
    @property
    def orientation(self) -> Array:
        """V, shape ``(4, 4)``."""
    @property
    def natural(self) -> Array:
        """``M = V diag(z) Vᵀ``, shape ``(4, 4)``."""
    @property
    def mode(self) -> Optional[Array]:
        """The mode (w ≥ 0), shape ``(4,)``, ``None`` when the largest eigenvalue is repeated."""
    def second_moment(self) -> Array:
        """``E[q qᵀ]``, shape ``(4, 4)``."""
    def entropy(self) -> float:
        """Differential entropy with respect to the uniform probability measure."""
    def kl_divergence(self, other: "Bingham") -> float:
        """``KL(self ‖ other)``."""

def bingham_log_normaliser(z: ArrayLike) -> Tuple[float, Array]:
    """The Bingham normaliser ``ln K(z)`` (uniform probability measure on S³) and its gradient
    ``∂ ln K/∂zₖ``, shape ``(4,)``, for eigenvalues ``z`` of shape ``(4,)`` in any order with a
    spread of at most 1e12."""

@final
class HeatKernelSo3:
    """The heat kernel on SO(3) (isotropic Brownian motion) with centre ``mean`` and per-axis
    variance s, with respect to the normalised Haar measure; s in [1e-300, inf)."""

    def __init__(self, mean: ArrayLike, variance: float) -> None:
        """Rotation matrix ``mean`` (3, 3) and variance ``s`` (rad²)."""
    def log_pdf(self, r: ArrayLike) -> FloatOrArray:
        """``ln p(R)`` for rotation matrices of shape ``(3, 3)`` or ``(..., 3, 3)``."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws, shape ``(n, 3, 3)``."""
    def log_normaliser(self) -> float:
        """0: the kernel is normalised."""
    def angle_pdf(self, t: ArrayLike) -> FloatOrArray:
        """Density of the rotation angle of ``meanᵀ R`` at angles ``t`` in [0, π]."""
    def angle_cdf(self, t: ArrayLike) -> FloatOrArray:
        """CDF of that angle at ``t`` in [0, π]."""
    def convolve(self, other: "HeatKernelSo3") -> "HeatKernelSo3":
        """The distribution of ``A B``: centres multiply, variances add (exact)."""
    @property
    def mean(self) -> Array:
        """The centre, shape ``(3, 3)``."""
    @property
    def variance(self) -> float:
        """s."""
    def first_moment(self) -> Array:
        """``E[R] = e^(−s) mean``, shape ``(3, 3)``."""
    def entropy(self) -> float:
        """Differential entropy with respect to the normalised Haar measure."""
    def kl_divergence(self, other: "HeatKernelSo3") -> float:
        """``KL(self ‖ other)`` (by quadrature)."""

@final
class ManifoldGaussianSo3:
    """The Gaussian ``R = mean · exp(δ)``, ``δ ~ N(0, P)``, on SO(3) (body-frame errors); the log
    density is with respect to the Lebesgue measure in the tangent coordinates δ."""

    def __init__(self, mean: ArrayLike, cov: ArrayLike) -> None:
        """Rotation matrix ``mean`` (3, 3) and symmetric positive definite ``cov`` (3, 3)."""
    @staticmethod
    def fit(samples: ArrayLike, weights: Optional[ArrayLike] = None) -> "ManifoldGaussianSo3":
        """The moment fit to rotation matrices ``samples`` (shape ``(n, 3, 3)``) with optional non-negative ``weights``
        (shape ``(n,)``): the weighted mean on the manifold (where the weighted tangent residuals
        average to zero) and the weighted scatter of the residuals; the maximum-likelihood fit as
        the spread goes to zero. Raises ``ValueError`` for invalid samples or weights, or too few
        distinct samples for a positive definite covariance."""
    def log_pdf(self, r: ArrayLike) -> FloatOrArray:
        """``ln p(R)`` for rotation matrices of shape ``(3, 3)`` or ``(..., 3, 3)``."""
    def mahalanobis_squared(self, r: ArrayLike) -> FloatOrArray:
        """``δᵀ P⁻¹ δ`` with ``δ = log(meanᵀ R)``."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws, shape ``(n, 3, 3)``."""
    def log_normaliser(self) -> float:
        """``½ (3 ln 2π + ln det P)``."""
    def compose(self, other: "ManifoldGaussianSo3") -> "ManifoldGaussianSo3":
        """First-order distribution of ``A B`` for independent ``A ~ self``, ``B ~ other``."""
    @property
    def mean(self) -> Array:
        """The mean rotation, shape ``(3, 3)``."""
    @property
    def covariance(self) -> Array:
        """P, shape ``(3, 3)``."""
    def entropy(self) -> float:
        """Entropy with respect to the tangent Lebesgue measure."""
    def kl_divergence(self, other: "ManifoldGaussianSo3") -> float:
        """``KL(self ‖ other)``; ``ValueError`` unless the means coincide."""

@final
class ManifoldGaussianS2:
    """The Gaussian ``x = exp_μ(B(μ) δ)``, ``δ ~ N(0, P)``, on S², in the two tangent coordinates
    of the basis ``tangent_basis()``; the log density is with respect to the Lebesgue measure in δ."""

    def __init__(self, mean: ArrayLike, cov: ArrayLike) -> None:
        """Unit vector ``mean`` (3,) and symmetric positive definite ``cov`` (2, 2)."""
    @staticmethod
    def fit(samples: ArrayLike, weights: Optional[ArrayLike] = None) -> "ManifoldGaussianS2":
        """The moment fit to unit vectors ``samples`` (shape ``(n, 3)``) with optional non-negative ``weights``
        (shape ``(n,)``): the weighted mean on the manifold (where the weighted tangent residuals
        average to zero) and the weighted scatter of the residuals; the maximum-likelihood fit as
        the spread goes to zero. Raises ``ValueError`` for invalid samples or weights, or too few
        distinct samples for a positive definite covariance."""
    def log_pdf(self, x: ArrayLike) -> FloatOrArray:
        """``ln p(x)`` for unit vectors of shape ``(3,)`` or ``(..., 3)``."""
    def mahalanobis_squared(self, x: ArrayLike) -> FloatOrArray:
        """``δᵀ P⁻¹ δ`` with ``δ = B(μ)ᵀ log_μ(x)``."""
    def sample(self, n: int, rng: np.random.Generator) -> Array:
        """``n`` draws, shape ``(n, 3)``."""
    def log_normaliser(self) -> float:
        """``½ (2 ln 2π + ln det P)``."""
    @property
    def mean(self) -> Array:
        """μ, shape ``(3,)``."""
    @property
    def covariance(self) -> Array:
        """P, shape ``(2, 2)``."""
    def tangent_basis(self) -> Array:
        """``B(μ) = [b1 b2]``, shape ``(3, 2)``, orthonormal with ``b1 × b2 = μ``."""
    def entropy(self) -> float:
        """Entropy with respect to the tangent Lebesgue measure."""
    def kl_divergence(self, other: "ManifoldGaussianS2") -> float:
        """``KL(self ‖ other)``; ``ValueError`` unless the means coincide."""
