"""faultlab.metrics"""
