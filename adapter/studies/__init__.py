"""The studies: numerics (stable steps, orders), the chooser, calibration, the flow study and
its grid-convergence index. May import every room below them."""
