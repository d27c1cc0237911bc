"""The nonlinear model: the state layout, Eqs. (18)-(24), their compiled kernels, integration."""
