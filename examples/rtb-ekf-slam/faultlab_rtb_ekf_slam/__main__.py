"""``python -m faultlab_rtb_ekf_slam``: the toolbox's EKF-SLAM speaking faultlab's process protocol on stdin/stdout.

Noise settings come from the environment (``RTB_EKF_STD_V``, ``RTB_EKF_STD_OMEGA_DEG``, ``RTB_EKF_STD_RANGE``,
``RTB_EKF_STD_BEARING_DEG``; defaults: the paper's setup).
"""

import os

from faultlab.slam.serve import serve
from faultlab_rtb_ekf_slam import RtbEkfSlam, _toolbox

_ENV = {"std_v": "RTB_EKF_STD_V", "std_omega_deg": "RTB_EKF_STD_OMEGA_DEG", "std_range": "RTB_EKF_STD_RANGE",
        "std_bearing_deg": "RTB_EKF_STD_BEARING_DEG"}

if __name__ == "__main__":
    _toolbox()  # import the toolbox before the first request, not while it waits for a reply
    options = {key: float(os.environ[name]) for key, name in _ENV.items() if name in os.environ}
    raise SystemExit(serve(lambda: RtbEkfSlam(**options)))
