"""faultlab.scenario"""
