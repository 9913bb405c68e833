"""Model-based control on the analytic model: the references the learners are measured against."""
