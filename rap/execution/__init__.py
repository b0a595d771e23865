"""What happens when a plan is executed: whole-plan rollouts with errors carried from step to step,
sequence success and its interval, each step's clearance and tolerance, and choosing among plans by
what they measure. No ray, no torch; the farm fans the rollouts out (``rap.farm.rollouts``)."""
