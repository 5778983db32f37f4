from typing import Any

#: Coefficients of the five-term series of the inverse Langevin function.
AB_COEFFS = (1.0 / 2.0, 1.0 / 20.0, 11.0 / 1050.0, 19.0 / 7000.0, 519.0 / 673750.0)


def arruda_boyce(I1: Any, I2: Any, *, mu: float, lambda_m: float, xp: Any) -> Any:
    r"""Arruda–Boyce eight-chain strain energy, five-term series (as in Abaqus).

    .. math:: W = \mu \sum_{i=1}^{5} \frac{C_i}{\lambda_m^{2i-2}} (I_1^i - 3^i),
        \quad C = \tfrac12, \tfrac1{20}, \tfrac{11}{1050}, \tfrac{19}{7000}, \tfrac{519}{673750}

    Small-strain shear modulus
    :math:`\mu_0 = \mu (1 + \tfrac{3}{5\lambda_m^2} + \tfrac{99}{175\lambda_m^4}
    + \tfrac{513}{875\lambda_m^6} + \tfrac{42039}{67375\lambda_m^8})`.

    Parameters
    ----------
    I1, I2 : array_like
        Invariants of the (isochoric) right Cauchy–Green tensor (-); I2 is unused.
    mu : float
        Rubbery modulus μ (Pa) (not the initial shear modulus μ0).
    lambda_m : float
        Locking chain stretch (-).
    xp : namespace
        Math namespace (unused).

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> float(arruda_boyce(3.0, 3.0, mu=1.0, lambda_m=5.0, xp=JAX_MATH))
    0.0

    References
    ----------
    E. M. Arruda, M. C. Boyce, A three-dimensional constitutive model for the large stretch
    behavior of rubber elastic materials, J. Mech. Phys. Solids 41 (1993) 389–412,
    doi:10.1016/0022-5096(93)90013-6.
    """
    w = 0.0 * I1
    for i, ci in enumerate(AB_COEFFS, start=1):
        w = w + ci / lambda_m ** (2 * i - 2) * (I1**i - 3.0**i)
    return mu * w
