"""Model-based control on the analytic model (no simulator): the env's step on arrays of states,
energy pumping, LQR at upright and the bound no bounded controller beats, the minimum-time search,
and fixed baseline policies. These are the references the learners are measured against.
"""
