"""faultlab.runner"""
