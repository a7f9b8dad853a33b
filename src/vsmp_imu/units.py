"""Physical constants and unit factors: one definition each, with its unit and source.

Every room imports these instead of typing the number; a reading in g or in
degrees is converted with the factors here and nowhere else.
"""

from __future__ import annotations

import math

# Standard acceleration of gravity g_n, m/s^2 (exact by definition: 3rd CGPM, 1901;
# ISO 80000-3:2019, item 3-9.1). The simulator's world gravity and every "g" factor.
STANDARD_GRAVITY_M_S2 = 9.80665

# Plane angle: 1 degree = pi/180 rad (SI Brochure, 9th ed., Table 8; ISO 80000-3, item 3-5).
RAD_PER_DEG = math.pi / 180.0
DEG_PER_RAD = 180.0 / math.pi
