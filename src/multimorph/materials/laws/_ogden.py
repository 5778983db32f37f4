from typing import Any


def ogden(l1: Any, l2: Any, l3: Any, *, xp: Any, **p: float) -> Any:
    r"""N-term Ogden strain energy in the Ogden (1972) convention, of principal stretches.

    .. math:: W = \sum_{p=1}^{N} \frac{\mu_p}{\alpha_p}
        \left(\lambda_1^{\alpha_p} + \lambda_2^{\alpha_p} + \lambda_3^{\alpha_p} - 3\right),
        \qquad \mu = \tfrac12 \sum_p \mu_p \alpha_p

    The Abaqus convention writes :math:`2\mu_p/\alpha_p^2` in front, so
    :math:`\mu_p^{1972} = 2 \mu_p^{Abaqus} / \alpha_p`;
    :class:`~multimorph.materials.Material` stores the convention and converts.

    Parameters
    ----------
    l1, l2, l3 : array_like
        Principal (isochoric) stretches (-).
    xp : namespace
        Math namespace (unused: powers are plain ``**``).
    **p : float
        ``mu1, …, muN`` (Pa) and ``alpha1, …, alphaN`` (-), 1972 convention.

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> float(ogden(1.0, 1.0, 1.0, mu1=1.0, alpha1=2.0, xp=JAX_MATH))
    0.0

    References
    ----------
    R. W. Ogden, Large deformation isotropic elasticity — on the correlation of theory and
    experiment for incompressible rubberlike solids, Proc. R. Soc. A 326 (1972) 565–584,
    doi:10.1098/rspa.1972.0026.
    """
    n = len(p) // 2
    w = 0.0 * l1
    for i in range(1, n + 1):
        mu, a = p[f"mu{i}"], p[f"alpha{i}"]
        w = w + mu / a * (l1**a + l2**a + l3**a - 3.0)
    return w
