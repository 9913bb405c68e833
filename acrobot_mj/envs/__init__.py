"""The environments: tasks (what is rewarded, when an episode ends, how results are scored), the
MuJoCo env and its batched vector form, the one episode loop, model files and the headless GL
backend.

This package's ``__init__`` imports nothing: ``import acrobot_mj`` loads :mod:`.gl` before
anything imports MuJoCo (MuJoCo fixes its GL backend when it is imported).
"""
