"""Model-based control on the analytic model (no simulator): fixed and energy-pumping policies,
the minimum-time search, LQR at upright and its bounds, identification, trajectory optimisation
and TVLQR along a swing-up. These are the references the learners are measured against.
"""
