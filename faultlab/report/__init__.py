"""faultlab.report"""
