"""The physics of the acrobot, with no simulator: parameters, the equations of motion in
manipulator form, integrators, angle wrapping and the report's printed equations (errata).

Nothing here imports MuJoCo; the environments (:mod:`acrobot_mj.envs`) are checked against these
functions (``tests/test_crosscheck.py``).
"""
