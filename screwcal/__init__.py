"""screwcal: the estimation core (screw kinematics, identification, ISO 9283 metrics).

Pure numpy/scipy maths and file formats; imports nothing of `protocol`, `simulators` or `service`.
Units: mm and degrees at every interface, radians only inside numeric code.
"""

from screwcal.errors import ScrewcalError

__all__ = ["ScrewcalError"]
__version__ = "0.1.0"
