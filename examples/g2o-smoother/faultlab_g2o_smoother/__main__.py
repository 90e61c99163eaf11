"""``python -m faultlab_g2o_smoother``: the g2o smoother speaking faultlab's process protocol on stdin/stdout."""

from faultlab.slam.serve import serve
from faultlab_g2o_smoother import G2oSmoother

if __name__ == "__main__":
    raise SystemExit(serve(G2oSmoother))
