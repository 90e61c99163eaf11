"""faultlab.slam"""
