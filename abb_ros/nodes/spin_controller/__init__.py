"""The spin controller node: node, parameters, run-up and speed loop."""
