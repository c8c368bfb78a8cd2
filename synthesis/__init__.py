"""synthesis — finite-position synthesis of spatial dyads from screw displacements (seed 001).

Not implemented yet (issue 3): screws, RR links through three positions, RRR / RRS / PRS
dyads, variant tables verified by the closure engine.
"""
