"""faultlab.space"""
