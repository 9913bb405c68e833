"""The AI Olympics protocol for the acrobot (dfki-ric-underactuated-lab/double_pendulum, its
leaderboards): its constants and levels (:mod:`~acrobot_mj.olympics.protocol`), its scores
(:mod:`~acrobot_mj.olympics.scores`) and their record and figures
(:mod:`~acrobot_mj.olympics.report`)."""
