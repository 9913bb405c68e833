"""Training: configs and presets, the learners (one interface for everything trained or planned),
their runs and run directories, evaluation and videos of any run, several seeds (in lockstep
where the algorithm allows) and sweeps.

Start with :func:`acrobot_mj.train.trainer.train` and :data:`acrobot_mj.train.presets.PRESETS`.
"""
