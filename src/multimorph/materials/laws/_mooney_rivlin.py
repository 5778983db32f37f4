from typing import Any


def mooney_rivlin(I1: Any, I2: Any, *, c10: float, c01: float, xp: Any) -> Any:
    r"""Two-parameter Mooney–Rivlin strain energy (incompressible / isochoric part).

    .. math:: W = C_{10} (I_1 - 3) + C_{01} (I_2 - 3), \qquad \mu = 2 (C_{10} + C_{01})

    Parameters
    ----------
    I1, I2 : array_like
        Invariants of the (isochoric) right Cauchy–Green tensor (-).
    c10, c01 : float
        Material constants (Pa).
    xp : namespace
        Math namespace (unused).

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> float(mooney_rivlin(4.0, 5.0, c10=1.0, c01=0.5, xp=JAX_MATH))
    2.0

    References
    ----------
    M. Mooney, A theory of large elastic deformation, J. Appl. Phys. 11 (1940) 582,
    doi:10.1063/1.1712836; R. S. Rivlin, Phil. Trans. R. Soc. A 241 (1948) 379,
    doi:10.1098/rsta.1948.0024.
    """
    return c10 * (I1 - 3.0) + c01 * (I2 - 3.0)
