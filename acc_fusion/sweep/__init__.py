"""Monte Carlo sweeps: axes, expansion into chunks, executors (local, Ray), the resumable store,
aggregation and the report.
"""
