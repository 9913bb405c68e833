"""Training: configs and presets, learners, runs and their directories, evaluation, seeds and
sweeps. Start with :func:`acrobot_mj.train.trainer.train` and its presets (``PRESETS``)."""
