"""Basins of attraction: the probability of balancing from many starts (docs/basin.md)."""
