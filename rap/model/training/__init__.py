"""Training the robustness CNN: named recipes, the training run in steps, its rows and hold-outs, and the epoch states that let an interrupted run resume bit-identically. Torch; no ray."""
