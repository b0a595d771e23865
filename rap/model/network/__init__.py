"""The robustness CNN itself: its config and layers, its output heads (class or binomial) and the checkpoint file that carries both with the weights. Torch; no ray."""
