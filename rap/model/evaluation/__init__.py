"""How good a checkpoint is: cross-validation folds by assembly and by family, held-out predictions and their metrics (accuracy, calibration, noise ceiling). Torch; no ray."""
