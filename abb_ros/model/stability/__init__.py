"""Stability: equilibria, linearisation, Floquet multipliers, speed bands, where balls settle."""
