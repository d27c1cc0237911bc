"""Design studies over many drives: `abb-sim sweep` on Dask (docs/sweep.md)."""
