"""The continuation engine: one problem protocol and the drivers that use it.

Layer 8: natural continuation with fold detection, pseudo-arclength, and fold-curve
(two-parameter) continuation; knows nothing of the sheet.
"""
