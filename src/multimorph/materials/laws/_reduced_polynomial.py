from typing import Any


def reduced_polynomial(I1: Any, I2: Any, *, xp: Any, **c: float) -> Any:
    r"""Reduced polynomial strain energy of order N = 1..6 (Yeoh for N = 3).

    .. math:: W = \sum_{i=1}^{N} C_{i0} (I_1 - 3)^i, \qquad \mu = 2 C_{10}

    This is the form the reference paper fitted with Abaqus (N = 6).

    Parameters
    ----------
    I1, I2 : array_like
        Invariants of the (isochoric) right Cauchy–Green tensor (-); I2 is unused.
    xp : namespace
        Math namespace (unused).
    **c : float
        Coefficients ``c10, c20, …, cN0`` (Pa), consecutive from ``c10``.

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> float(reduced_polynomial(4.0, 3.0, c10=1.0, c20=0.5, xp=JAX_MATH))
    1.5

    References
    ----------
    O. H. Yeoh, Some forms of the strain energy function for rubber, Rubber Chem. Technol.
    66 (1993) 754–771, doi:10.5254/1.3538343.
    """
    x = I1 - 3.0
    w = 0.0 * x
    for i in range(1, len(c) + 1):
        w = w + c[f"c{i}0"] * x**i
    return w
