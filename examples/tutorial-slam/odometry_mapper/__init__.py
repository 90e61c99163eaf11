"""The tutorial's odometry mapper (docs/tutorial/test-your-own-slam.md), packaged like a user's SLAM."""

from odometry_mapper.mapper import OdometryMapper, make

__all__ = ["OdometryMapper", "make"]
