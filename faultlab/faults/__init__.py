"""faultlab.faults"""
