"""postcapture: flexible multibody simulation and estimation for the post-capture phase.

A chaser spacecraft holds a large tumbling target (Envisat) through a 7-DoF manipulator with
flexible joints; both spacecraft carry flexible solar panels. The package simulates that system
with Pinocchio, generates sensor data, and estimates the chaser attitude and the target mass.

The curated public API is re-exported here; see the README for a tour.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("postcapture")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = ["__version__"]
