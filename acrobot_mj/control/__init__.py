"""Model-based control, on the analytic model or a learnt one: the references the learners are
measured against, trajectory optimisation, LQR and funnels, identification."""
