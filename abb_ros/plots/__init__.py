"""Figures (PNG, matplotlib Agg): time responses from bags, stability maps."""
