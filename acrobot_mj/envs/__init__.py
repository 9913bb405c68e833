"""The environments: tasks, the MuJoCo env and its vector form, the episode loop, model files
and headless GL. Imports nothing: ``import acrobot_mj`` must load :mod:`.gl` before MuJoCo.
"""
