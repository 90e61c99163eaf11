"""faultlab.stats"""
