"""Campaigns: one scenario end to end, Monte Carlo on Dask, results files, benchmarks."""
