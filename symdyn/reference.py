"""The numeric reference under its documented name, `symdyn.reference`: the
public functions of `symdyn.numeric.reference`, where the recursion lives.

Every function takes the robot first, then states of shape (n,) or (..., n)
whose leading shapes broadcast, and returns arrays with those leading axes.
Bad input is a `ValueError` naming the argument: a state that is not a numeric
array of the right last dimension, that contains NaN or infinity, leading
shapes that do not broadcast, a wrench that is not (6,) or (..., 6), a gravity
that is not a finite 3-vector.  `accel` raises `SingularInertia` (a
`ValueError`) where M(q) is singular, naming the joint that moves no mass;
`fdyn` a `ValueError` for a non-positive time and a `RuntimeError` when the
integrator fails.
"""

from .numeric.reference import *  # noqa: F403
from .numeric.reference import __all__  # noqa: F401
