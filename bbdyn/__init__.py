"""bbdyn: exact dynamics of the bouncing ball billiard.

Reproduces and extends Matyas & Klages, Physica D 187 (2004) 165.  Importing
bbdyn loads neither sympy nor matplotlib.
"""

from bbdyn.params import Params

__version__ = "0.1.0"
__all__ = ["Params", "__version__"]
