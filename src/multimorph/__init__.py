"""multimorph: design sequentially multimodal, single-input soft pneumatic actuators.

SI units inside (Pa, m); units are parsed at the edges (CLI, spec files) by
:mod:`multimorph.units`.
"""

from multimorph._jaxconfig import enable_x64 as _enable_x64

_enable_x64()

__version__ = "0.1.0"

__all__ = ["__version__"]
