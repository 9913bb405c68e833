"""The physics of the acrobot, with no simulator: parameters (:mod:`.params`), the equations of
motion (:mod:`.dynamics`), the one discrete step (:mod:`.integrators`), the math namespaces they
are written over (:mod:`.xp`) and the report's printed equations (:mod:`.errata`).
"""
