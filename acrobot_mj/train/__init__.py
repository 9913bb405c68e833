"""Training: the flat config and its presets, one run (a learner or a population), several
seeds (in lockstep where the algorithm allows), sweeps, and the run directory each writes
(records, checkpoints, resume).

Start with :func:`acrobot_mj.train.trainer.train` and :data:`acrobot_mj.train.presets.PRESETS`.
"""
