from typing import Any


def gent(I1: Any, I2: Any, *, mu: float, jm: float, xp: Any) -> Any:
    r"""Gent strain energy (incompressible / isochoric part) with limiting chain extensibility.

    .. math:: W = -\frac{\mu J_m}{2} \ln\!\left(1 - \frac{I_1 - 3}{J_m}\right)

    defined for :math:`I_1 - 3 < J_m` (lock-up). Small-strain shear modulus :math:`\mu`;
    :math:`J_m \to \infty` recovers neo-Hooke. This raw function returns NaN beyond lock-up;
    the public :class:`~multimorph.materials.Material` API checks first and raises
    :class:`~multimorph.errors.LockupError`.

    Parameters
    ----------
    I1, I2 : array_like
        Invariants of the (isochoric) right Cauchy–Green tensor (-); I2 is unused.
    mu : float
        Shear modulus (Pa).
    jm : float
        Limit of I1 − 3 (-).
    xp : namespace
        Math namespace providing ``log``.

    Examples
    --------
    >>> from multimorph.materials._math import JAX_MATH
    >>> round(float(gent(4.0, 3.0, mu=1.0, jm=20.0, xp=JAX_MATH)), 6)
    0.512933

    References
    ----------
    A. N. Gent, A new constitutive relation for rubber, Rubber Chem. Technol. 69 (1996) 59–61,
    doi:10.5254/1.3538357.
    """
    return -0.5 * mu * jm * xp.log(1.0 - (I1 - 3.0) / jm)
