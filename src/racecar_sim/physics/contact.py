"""Turn Gazebo contact tags (mu, kp, kd) into MuJoCo contact parameters.

Gazebo/ODE treats kp/kd implicitly (ERP, CFM), which keeps a 1e7 N/m contact rigid and stable at 1 ms.
Copied literally into MuJoCo's solref the same numbers diverge. What we keep is the *static stiffness*:
MuJoCo's contact is a spring-damper reference (time constant tc, critical damping) blended with a hard
constraint by the impedance d. At rest the penetration is r = (1 - d) g / (d k) with k = 1 / (d tc)^2, so
the equivalent stiffness per contact is K = m k d / (1 - d). Solving K = kp for d gives a contact as
stiff as Gazebo's, while tc (a free parameter, >= 2 steps) keeps it stable.
"""

from __future__ import annotations

import math

D_MAX = 0.9999  # MuJoCo's impedance must stay below 1


def impedance_for_stiffness(kp: float, sprung_mass: float, timeconst: float) -> float:
    """Impedance d such that a contact carrying `sprung_mass` has static stiffness kp (N/m)."""
    a = kp * timeconst**2 / sprung_mass
    if a <= 4.0:  # softer than the reference spring alone can give: fall back to MuJoCo's usual value
        return 0.9
    d = 0.5 * (1.0 + math.sqrt(1.0 - 4.0 / a))
    return min(d, D_MAX)


def solref_solimp(kp: float | None, sprung_mass: float, timeconst: float) -> tuple[list[float], list[float]]:
    """solref (timeconst, dampratio) and solimp (dmin, dmax, width, midpoint, power) for a surface."""
    if kp is None:
        kp = 1e12  # SDF's default surface kp
    d = impedance_for_stiffness(kp, sprung_mass, timeconst)
    # Critical damping: Gazebo's kd (1 N s/m) is ~1e-4 of critical and only its implicit step keeps it stable.
    return [timeconst, 1.0], [d, d, 0.001, 0.5, 2.0]
