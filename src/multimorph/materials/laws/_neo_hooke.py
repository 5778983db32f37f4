from typing import Any


def neo_hooke(I1: Any, I2: Any, *, mu: float, xp: Any) -> Any:
    r"""Neo-Hookean strain energy per reference volume (incompressible / isochoric part).

    .. math:: W = \frac{\mu}{2} (I_1 - 3)

    Parameters
    ----------
    I1, I2 : array_like
        First and second invariants of the (isochoric) right Cauchy–Green tensor (-).
    mu : float
        Shear modulus (Pa).
    xp : namespace
        Math namespace (unused here; kept for a uniform signature).

    Returns
    -------
    W : array_like
        Strain energy density (J/m³ = Pa).

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> float(neo_hooke(4.0, 3.0, mu=2.0, xp=JAX_MATH))
    1.0

    References
    ----------
    L. R. G. Treloar, The elasticity of a network of long-chain molecules,
    Trans. Faraday Soc. 39 (1943) 36–41, doi:10.1039/TF9433900036.
    """
    return 0.5 * mu * (I1 - 3.0)
