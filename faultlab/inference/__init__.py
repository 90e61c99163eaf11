"""Inference on arrays: exact tests, multiplicity, sequential designs, power and sample size, screening.

The computation layer's statistics.  Every function takes numbers or numpy arrays and returns numbers,
numpy arrays or small frozen dataclasses; nothing here reads a store or builds a table of results
(that is :mod:`faultlab.stats`, above the runner).  The runner and the campaigns call this layer
directly: the stopping rule of adaptive repetitions (:mod:`faultlab.inference.sequential`) and the
screening of an effects study sit here so that both can.
"""
